#include "postgres_server.h"

#include <algorithm>
#include <cstdlib>
#include <fcntl.h>
#include <fstream>
#include <grp.h>
#include <pqxx/pqxx>
#include <pwd.h>
#include <sstream>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

namespace psrig::test {
namespace {

namespace fs = std::filesystem;

// Who runs the server: this process's user, or the `postgres` system user
// when this is root.
struct ServerUser {
  uid_t uid;
  gid_t gid;
};

std::optional<ServerUser> server_user() {
  if (::geteuid() != 0) return ServerUser{::geteuid(), ::getegid()};
  const passwd* user = ::getpwnam("postgres");
  if (!user) return std::nullopt;
  return ServerUser{user->pw_uid, user->pw_gid};
}

// Runs `argv` as `user` in `directory`, its output appended to `log`; its
// exit status.
int run_as(const ServerUser& user, const std::vector<std::string>& argv, const fs::path& directory,
           const fs::path& log) {
  std::vector<char*> args;
  for (const auto& arg : argv)
    args.push_back(const_cast<char*>(arg.c_str()));
  args.push_back(nullptr);
  const pid_t child = ::fork();
  if (child == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    if (fd >= 0) {
      ::dup2(fd, 1);
      ::dup2(fd, 2);
      ::close(fd);
    }
    if (::geteuid() == 0 &&
        (::setgroups(0, nullptr) != 0 || ::setgid(user.gid) != 0 || ::setuid(user.uid) != 0))
      ::_exit(126);
    if (::chdir(directory.c_str()) != 0) ::_exit(126);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  int status = 0;
  if (child < 0 || ::waitpid(child, &status, 0) != child) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

std::string read_text(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// An initdb'd data directory kept between test programs (ctest runs each
// test as a program of its own): copying it takes a tenth of initdb's
// second and a half. One per user and server version; made whole or not
// at all (renamed into place), so test programs running at once can race
// to make it.
std::optional<fs::path> data_template(const fs::path& bin, const ServerUser& user,
                                      std::string& why_not) {
  const std::string version = bin.parent_path().filename().string();
  const fs::path cache = fs::temp_directory_path() /
                         ("psrig-postgres-template-" + std::to_string(user.uid) + "-" + version);
  std::error_code ec;
  if (fs::is_regular_file(cache / "PG_VERSION", ec)) return cache;
  TempDir staging("psrig-postgres-initdb");
  fs::permissions(staging.path(), fs::perms::owner_all | fs::perms::group_exec |
                                      fs::perms::others_exec);
  const fs::path data = staging.path() / "data";
  const fs::path log = staging.path() / "initdb.log";
  fs::create_directory(data);
  ::close(::open(log.c_str(), O_WRONLY | O_CREAT, 0666));
  if (::chown(data.c_str(), user.uid, user.gid) != 0 || ::chown(log.c_str(), user.uid, user.gid) != 0) {
    why_not = "cannot give " + data.string() + " to the server's user";
    return std::nullopt;
  }
  if (run_as(user,
             {(bin / "initdb").string(), "-D", data.string(), "-A", "trust", "-U", "psrig", "-E",
              "UTF8", "--locale=C", "--no-sync"},
             staging.path(), log) != 0) {
    why_not = "initdb failed:\n" + read_text(log);
    return std::nullopt;
  }
  fs::rename(data, cache, ec);  // another program may have been first: theirs is as good
  if (fs::is_regular_file(cache / "PG_VERSION", ec)) return cache;
  why_not = "cannot keep the initdb template at " + cache.string();
  return std::nullopt;
}

}  // namespace

std::optional<fs::path> postgres_bin_dir() {
  const auto has_tools = [](const fs::path& dir) {
    std::error_code ec;
    return fs::is_regular_file(dir / "initdb", ec) && fs::is_regular_file(dir / "pg_ctl", ec);
  };
  if (const char* given = std::getenv("PSRIG_POSTGRES_BIN"); given && *given)
    return has_tools(given) ? std::optional<fs::path>(given) : std::nullopt;
  std::vector<fs::path> versions;
  std::error_code ec;
  for (fs::directory_iterator it("/usr/lib/postgresql", ec), end; !ec && it != end; it.increment(ec))
    if (has_tools(it->path() / "bin")) versions.push_back(it->path() / "bin");
  if (!versions.empty()) {
    // The newest major version: "15" > "13", and "9.6" < "10" by number.
    std::sort(versions.begin(), versions.end(), [](const fs::path& a, const fs::path& b) {
      return std::atof(a.parent_path().filename().c_str()) <
             std::atof(b.parent_path().filename().c_str());
    });
    return versions.back();
  }
  if (const char* path = std::getenv("PATH")) {
    std::stringstream dirs(path);
    for (std::string dir; std::getline(dirs, dir, ':');)
      if (!dir.empty() && has_tools(dir)) return fs::path(dir);
  }
  return std::nullopt;
}

std::unique_ptr<PostgresServer> PostgresServer::start(Options options, std::string& why_not) {
  const auto bin = postgres_bin_dir();
  if (!bin) {
    why_not =
        "the PostgreSQL server's programs (initdb, pg_ctl) are not installed: apt-get install "
        "postgresql-15 (scripts/install-deps does), or set PSRIG_POSTGRES_BIN";
    return nullptr;
  }
  const auto user = server_user();
  if (!user) {
    why_not = "running as root and there is no `postgres` user to run the server as (postgres "
              "refuses root); Debian's postgresql-15 package makes one";
    return nullptr;
  }
  std::unique_ptr<PostgresServer> server(new PostgresServer());
  server->temp_ = std::make_unique<TempDir>("psrig-postgres");
  server->bin_ = *bin;
  server->options_ = options;
  server->data_ = server->temp_->path() / "data";
  server->socket_ = server->temp_->path() / "socket";
  fs::permissions(server->temp_->path(), fs::perms::owner_all | fs::perms::group_exec |
                                             fs::perms::others_exec);
  fs::create_directory(server->socket_);
  if (::chown(server->socket_.c_str(), user->uid, user->gid) != 0 ||
      ::chown(server->temp_->path().c_str(), user->uid, user->gid) != 0) {
    why_not = "cannot give " + server->temp_->path().string() + " to the server's user";
    return nullptr;
  }
  const auto data_template_dir = data_template(*bin, *user, why_not);
  if (!data_template_dir) return nullptr;
  const fs::path log = server->temp_->path() / "server.log";
  ::close(::open(log.c_str(), O_WRONLY | O_CREAT, 0666));
  if (::chown(log.c_str(), user->uid, user->gid) != 0) {
    why_not = "cannot give " + log.string() + " to the server's user";
    return nullptr;
  }
  if (run_as(*user, {"/bin/cp", "-a", data_template_dir->string(), server->data_.string()},
             server->temp_->path(), log) != 0 ||
      !server->pg_ctl("start")) {
    why_not = "the PostgreSQL server did not start:\n" + read_text(log);
    return nullptr;
  }
  return server;
}

bool PostgresServer::pg_ctl(const std::string& action) {
  const auto user = server_user();
  const fs::path log = temp_->path() / "server.log";
  std::vector<std::string> argv = {(bin_ / "pg_ctl").string(), "-D", data_.string(), "-w",
                                   "-t", "30"};
  if (action == "start") {
    argv.insert(argv.end(),
                {"-l", log.string(), "-o",
                 "-c listen_addresses='' -c unix_socket_directories='" + socket_.string() +
                     "' -c fsync=" + (options_.fsync ? "on" : "off") +
                     " -c max_connections=200", "start"});
  } else {
    argv.insert(argv.end(), {"-m", action, "stop"});
  }
  return user && run_as(*user, argv, temp_->path(), temp_->path() / "pg_ctl.log") == 0;
}

PostgresServer::~PostgresServer() {
  (void)pg_ctl("immediate");
}

bool PostgresServer::stop() {
  return pg_ctl("fast");
}

bool PostgresServer::start_again() {
  return pg_ctl("start");
}

std::string PostgresServer::log() const {
  return read_text(temp_->path() / "server.log");
}

std::string PostgresServer::url(const std::string& database) const {
  // libpq's URI: an absolute host is a socket directory (percent-encoded here).
  std::string host;
  for (const char c : socket_.string())
    host += c == '/' ? std::string("%2F") : std::string(1, c);
  return "postgresql://psrig@" + host + "/" + database;
}

std::string PostgresServer::create_database() {
  const std::string name = "test_" + std::to_string(::getpid()) + "_" + std::to_string(++databases_);
  const std::string failed = execute_sql(url("postgres"), "CREATE DATABASE " + name);
  if (!failed.empty()) throw std::runtime_error("CREATE DATABASE " + name + ": " + failed);
  return url(name);
}

PostgresServer* shared_postgres(std::string& why_not) {
  static std::string reason;
  static std::unique_ptr<PostgresServer> server = PostgresServer::start({}, reason);
  why_not = reason;
  return server.get();
}

std::string execute_sql(const std::string& url, const std::string& sql) {
  try {
    pqxx::connection connection(url);
    pqxx::nontransaction transaction(connection);
    transaction.exec(sql);
    return "";
  } catch (const std::exception& e) {
    return e.what();
  }
}

}  // namespace psrig::test
