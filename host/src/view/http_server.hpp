#pragma once
// A small HTTP/1.1 server on one event loop (Boost.Beast over Asio): every
// connection, however slow, idle or hostile, costs a socket and a buffer,
// never a thread. Requests are screened on their head before any body is
// read; what they ask is served on worker threads, control on a thread of
// its own, so Stop and E-stop never wait behind reads, streams or strangers.

#include <atomic>
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <utility>  // std::pair; and, included first, std::exchange for Boost 1.74's Asio
#include <vector>

namespace piezo::host::view {

struct HttpRequest {
  std::string method, path;  ///< the path without its query
  std::map<std::string, std::string> query;
  std::map<std::string, std::string> headers;  ///< names in lower case
  std::string body;

  [[nodiscard]] std::string header(const std::string& lower_case_name) const;
  [[nodiscard]] std::string param(const std::string& name) const;
};

struct HttpReply {
  int status = 200;
  std::string content_type = "application/json";
  std::string body;
  std::vector<std::pair<std::string, std::string>> headers;
  /// Set: the reply is an event stream (text/event-stream), and this gives
  /// its next event's data, called every stream period from a worker thread
  /// (never twice at once) while the page reads. Destroyed when it closes.
  std::function<std::string()> events;
};

/// What the server asks its owner.
struct HttpHandler {
  /// On the event loop, with the head only: a reply refuses the request
  /// before its body is read (the connection then closes).
  std::function<std::optional<HttpReply>(const HttpRequest& head)> screen;
  /// Whether a (screened) request is control: served on the control thread.
  std::function<bool(const HttpRequest&)> is_control;
  /// Serves a request on a worker thread; an exception is a 500 with its text.
  std::function<HttpReply(const HttpRequest&)> serve;
};

struct HttpLimits {
  std::size_t max_body = 64 * 1024;   ///< larger bodies: 413, unread
  std::size_t max_connections = 512;  ///< beyond: closed at once
  /// A request's head and body must come within this, and an idle
  /// connection is closed after it: a slow sender holds nothing for long.
  std::chrono::seconds request_deadline{10};
  std::chrono::milliseconds stream_period{250};
  std::size_t read_threads = 2;
};

class HttpServer {
 public:
  /// Binds HOST:PORT (port 0: any free one; throws with the reason when it
  /// cannot) and serves from threads of its own.
  HttpServer(const std::string& host, int port, HttpHandler handler, HttpLimits limits = {});
  ~HttpServer();
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  [[nodiscard]] int port() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace piezo::host::view
