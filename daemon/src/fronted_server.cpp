#include "fronted_server.h"

#include <sys/socket.h>
#include <unistd.h>

#include "request_stream.h"

namespace psrig::daemon {
namespace {

// httplib hands each accepted connection to a task queue; this one hands it
// straight to the front, on the accept thread (the front only files it).
class HandToFront final : public httplib::TaskQueue {
 public:
  void enqueue(std::function<void()> fn) override { fn(); }
  void shutdown() override {}
};

}  // namespace

FrontedServer::FrontedServer(ServingLimits limits, HttpFront::IsSafety is_safety)
    : limits_(limits),
      general_(std::make_unique<httplib::ThreadPool>(std::max(1, limits.general_threads))),
      safety_(std::make_unique<httplib::ThreadPool>(std::max(1, limits.safety_threads))) {
  new_task_queue = [] { return new HandToFront; };
  front_ = std::make_unique<HttpFront>(limits.front, std::move(is_safety),
                                       [this](ArrivedRequest request) { take(std::move(request)); });
}

FrontedServer::~FrontedServer() {
  stop_serving();
}

bool FrontedServer::process_and_close_socket(socket_t sock) {
  front_->add(sock);
  return true;
}

void FrontedServer::take(ArrivedRequest request) {
  std::lock_guard lock(mutex_);
  if (stopping_) {
    ::close(request.fd);
    return;
  }
  std::size_t in_lane = 0, from_peer = 0;
  for (const auto& [fd, taken] : in_flight_) {
    if (taken.lane != request.lane) continue;
    ++in_lane;
    if (taken.peer == request.peer) ++from_peer;
  }
  const bool safety = request.lane == Lane::safety;
  std::string refusal;
  if (safety && from_peer >= limits_.max_safety_in_flight_per_peer)
    refusal = "too many lights-off and status requests in progress from " + request.peer;
  else if (!safety && from_peer >= limits_.max_in_flight_per_peer)
    refusal = "too many requests in progress from " + request.peer + "; retry when one is answered";
  else if (!safety && in_lane >= limits_.max_in_flight)
    refusal = "too many requests in progress; retry shortly";
  if (!refusal.empty()) {
    answer_and_close(request.fd, closing_answer(503, "Service Unavailable", refusal));
    return;
  }
  in_flight_[request.fd] = {request.peer, request.lane};
  (safety ? safety_ : general_)->enqueue([this, request]() mutable { serve(std::move(request)); });
}

void FrontedServer::serve(ArrivedRequest request) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) {
      in_flight_.erase(request.fd);
      ::close(request.fd);
      return;
    }
  }
  RequestStream stream(request.fd, std::move(request.already_read),
                       request.accepted + limits_.front.request_deadline, limits_.write_timeout);
  bool connection_closed = false;
  process_request(stream, /*close_connection=*/true, connection_closed, nullptr);
  std::lock_guard lock(mutex_);
  in_flight_.erase(request.fd);
  answer_and_close(request.fd, "");
}

void FrontedServer::stop_serving() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    stopping_ = true;
    // Reads in progress end now; answers being written go on.
    for (const auto& [fd, taken] : in_flight_)
      ::shutdown(fd, SHUT_RD);
  }
  front_->stop();
  general_->shutdown();
  safety_->shutdown();
}

}  // namespace psrig::daemon
