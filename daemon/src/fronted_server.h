#pragma once
// httplib's server behind psrigd's own front (http_front.h): httplib still
// accepts, parses, routes and answers, but a connection reaches its parser
// only once the front has its request, on a thread of that request's lane,
// and each is read under a whole-request deadline (request_stream.h). One
// request per connection: a kept-alive connection would hold a thread while
// its next request dripped in.

#include <chrono>
#include <cstddef>
#include <httplib.h>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "http_front.h"

namespace psrig::daemon {

struct ServingLimits {
  FrontLimits front;
  int general_threads = 8;  // event streams included
  int safety_threads = 2;
  std::chrono::milliseconds write_timeout{5000};
  std::size_t max_in_flight = 128;          // general requests taken, unfinished, in all
  std::size_t max_in_flight_per_peer = 16;  // ... from one address
  std::size_t max_safety_in_flight_per_peer = 4;
};

class FrontedServer : public httplib::Server {
 public:
  FrontedServer(ServingLimits limits, HttpFront::IsSafety is_safety);
  ~FrontedServer() override;

  // After httplib's stop(): closes the waiting connections, ends the reads
  // in progress and waits for the requests being answered. Idempotent.
  void stop_serving();

 private:
  // Called by httplib's accept loop, on its thread, for each connection.
  bool process_and_close_socket(socket_t sock) override;
  void take(ArrivedRequest request);   // on the front's thread
  void serve(ArrivedRequest request);  // on a lane's thread

  struct InFlight {
    std::string peer;
    Lane lane;
  };
  const ServingLimits limits_;
  std::mutex mutex_;
  std::map<int, InFlight> in_flight_;  // by descriptor; closed under mutex_
  bool stopping_ = false;
  std::unique_ptr<httplib::ThreadPool> general_;
  std::unique_ptr<httplib::ThreadPool> safety_;
  std::unique_ptr<HttpFront> front_;
};

}  // namespace psrig::daemon
