#include "http_server.hpp"

#include <fmt/format.h>

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <cctype>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <utility>

#include "gzip_stream.hpp"

namespace piezo::host::view {
namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = asio::ip::tcp;

namespace {

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::string percent_decoded(std::string_view s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '+') {
      out += ' ';
    } else if (s[i] == '%' && i + 2 < s.size() && std::isxdigit(s[i + 1]) &&
               std::isxdigit(s[i + 2])) {
      out += static_cast<char>(std::stoi(std::string(s.substr(i + 1, 2)), nullptr, 16));
      i += 2;
    } else {
      out += s[i];
    }
  }
  return out;
}

void split_target(std::string_view target, HttpRequest& request) {
  const auto q = target.find('?');
  request.path = std::string(target.substr(0, q));
  if (q == std::string_view::npos) return;
  std::string_view rest = target.substr(q + 1);
  while (!rest.empty()) {
    const auto amp = rest.find('&');
    const std::string_view pair = rest.substr(0, amp);
    const auto eq = pair.find('=');
    request.query[percent_decoded(pair.substr(0, eq))] =
        eq == std::string_view::npos ? "" : percent_decoded(pair.substr(eq + 1));
    rest = amp == std::string_view::npos ? std::string_view{} : rest.substr(amp + 1);
  }
}

HttpReply plain_error(int status, const std::string& why) {
  return {status, "application/json", nlohmann::json{{"ok", false}, {"error", why}}.dump(), {}, {}};
}

}  // namespace

std::string HttpRequest::header(const std::string& lower_case_name) const {
  const auto it = headers.find(lower_case_name);
  return it == headers.end() ? "" : it->second;
}

std::string HttpRequest::param(const std::string& name) const {
  const auto it = query.find(name);
  return it == query.end() ? "" : it->second;
}

struct HttpServer::Impl {
  Impl(HttpHandler h, HttpLimits l)
      : handler(std::move(h)), limits(l), reads(l.read_threads), control(1) {}

  void accept();

  HttpHandler handler;
  HttpLimits limits;
  std::atomic<std::size_t> connections{0};
  asio::io_context ioc{1};
  tcp::acceptor acceptor{ioc};
  asio::steady_timer accept_pause{ioc};
  asio::thread_pool reads, control;
  std::thread loop;
};

namespace {

/// One connection, driven by the event loop alone; what it asks is served
/// on a worker thread and its reply posted back to the loop.
class Session : public std::enable_shared_from_this<Session> {
 public:
  Session(tcp::socket socket, HttpServer::Impl& server)
      : server_(server), stream_(std::move(socket)), timer_(stream_.get_executor()) {
    ++server_.connections;
  }
  ~Session() { --server_.connections; }

  void read_head() {
    head_.emplace();
    head_->header_limit(16 * 1024);
    // The head parser would refuse a large Content-Length itself, before
    // the head is screened; the limit is applied below, with an answer.
    // (Not boost::none: Boost 1.74 compares a length with an empty limit as
    // exceeding it.)
    head_->body_limit(std::numeric_limits<std::uint64_t>::max());
    stream_.expires_after(server_.limits.request_deadline);
    http::async_read_header(
        stream_, buffer_, *head_,
        [self = shared_from_this()](beast::error_code ec, std::size_t) { self->on_head(ec); });
  }

 private:
  void on_head(beast::error_code ec) {
    if (ec) return close();
    const auto& h = head_->get();
    request_ = {};
    request_.method = std::string(h.method_string());
    const auto target = h.target();
    split_target({target.data(), target.size()}, request_);
    for (const auto& field : h) {
      const auto name = field.name_string();
      request_.headers[lower({name.data(), name.size()})] = std::string(field.value());
    }
    keep_alive_ = h.keep_alive();
    if (auto refusal = server_.handler.screen(request_)) return refuse(std::move(*refusal));
    const auto length = head_->content_length();
    if (length && *length > server_.limits.max_body) {
      return refuse(
          plain_error(413, fmt::format("a body of at most {} bytes", server_.limits.max_body)));
    }
    if (!head_->chunked() && length.value_or(0) == 0) return dispatch();
    body_.emplace(std::move(*head_));
    body_->body_limit(server_.limits.max_body);
    http::async_read(stream_, buffer_, *body_,
                     [self = shared_from_this()](beast::error_code read_ec, std::size_t) {
                       self->on_body(read_ec);
                     });
  }

  void on_body(beast::error_code ec) {
    if (ec == http::error::body_limit) {
      return refuse(
          plain_error(413, fmt::format("a body of at most {} bytes", server_.limits.max_body)));
    }
    if (ec) return close();
    request_.body = std::move(body_->get().body());
    body_.reset();
    dispatch();
  }

  void dispatch() {
    stream_.expires_never();  // our reply is awaited, not the peer
    gzip_ = accepts_gzip(request_.header("accept-encoding"));
    auto& pool = server_.handler.is_control(request_) ? server_.control : server_.reads;
    asio::post(pool, [self = shared_from_this(), request = std::move(request_)] {
      HttpReply reply;
      try {
        reply = self->server_.handler.serve(request);
      } catch (const std::exception& e) {
        reply = plain_error(500, e.what());
      }
      asio::post(self->stream_.get_executor(),
                 [self, reply = std::move(reply)]() mutable { self->send(std::move(reply)); });
    });
  }

  /// A request refused on its head: answered, and the connection closed
  /// (its unread body is not a next request).
  void refuse(HttpReply reply) {
    keep_alive_ = false;
    send(std::move(reply));
  }

  void send(HttpReply reply) {
    if (reply.events) return start_stream(std::move(reply));
    auto res = std::make_shared<http::response<http::string_body>>(
        static_cast<http::status>(reply.status), 11);
    res->set(http::field::server, "piezo");
    res->set(http::field::content_type, reply.content_type);
    for (const auto& [name, value] : reply.headers) res->set(name, value);
    res->body() = std::move(reply.body);
    res->keep_alive(keep_alive_);
    res->prepare_payload();
    stream_.expires_after(server_.limits.request_deadline);
    http::async_write(stream_, *res,
                      [self = shared_from_this(), res](beast::error_code ec, std::size_t) {
                        if (ec) return self->close();
                        if (!self->keep_alive_) return self->linger_close();
                        self->read_head();
                      });
  }

  void start_stream(HttpReply reply) {
    events_ = std::move(reply.events);
    // Compressed where the reader takes gzip (browsers do): the events are
    // JSON of numbers, about a quarter of their size compressed.
    if (gzip_) gzip_stream_ = std::make_unique<GzipStream>();
    out_ = fmt::format(
        "HTTP/1.1 200 OK\r\nServer: piezo\r\nContent-Type: text/event-stream\r\n"
        "Cache-Control: no-cache\r\n{}Connection: close\r\n\r\n",
        gzip_ ? "Content-Encoding: gzip\r\n" : "");
    write_out();
  }

  /// The next event, computed on a worker; a page that reads slowly gets
  /// fewer, larger ones (each holds all it has not seen), never a queue.
  void next_event() {
    asio::post(server_.reads, [self = shared_from_this()] {
      std::string text;
      try {
        text = "data: " + self->events_() + "\n\n";
      } catch (const std::exception& e) {
        text = fmt::format("event: error\ndata: {}\n\n", e.what());
      }
      if (self->gzip_stream_) text = self->gzip_stream_->compress(text);
      asio::post(self->stream_.get_executor(), [self, text = std::move(text)]() mutable {
        self->out_ = std::move(text);
        self->write_out();
      });
    });
  }

  void write_out() {
    // A page that reads nothing for the deadline is closed.
    stream_.expires_after(server_.limits.request_deadline);
    asio::async_write(stream_, asio::buffer(out_),
                      [self = shared_from_this()](beast::error_code ec, std::size_t) {
                        if (ec) return self->close();
                        self->timer_.expires_after(self->server_.limits.stream_period);
                        self->timer_.async_wait([self](beast::error_code wait_ec) {
                          if (!wait_ec) self->next_event();
                        });
                      });
  }

  /// Half-closes and reads what the peer still sends for a moment, so that
  /// it reads our answer before the connection goes (closing on unread
  /// data would reset it), then closes.
  void linger_close() {
    beast::error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
    stream_.expires_after(std::chrono::seconds(1));
    drain();
  }
  void drain() {
    if (drained_ > 256 * 1024) return close();
    stream_.async_read_some(asio::buffer(sink_),
                            [self = shared_from_this()](beast::error_code ec, std::size_t n) {
                              self->drained_ += n;
                              if (ec) return self->close();
                              self->drain();
                            });
  }

  void close() {
    beast::error_code ec;
    timer_.cancel();
    stream_.socket().shutdown(tcp::socket::shutdown_both, ec);
    stream_.close();
  }

  HttpServer::Impl& server_;
  beast::tcp_stream stream_;
  beast::flat_buffer buffer_{16 * 1024};
  asio::steady_timer timer_;
  std::optional<http::request_parser<http::empty_body>> head_;
  std::optional<http::request_parser<http::string_body>> body_;
  HttpRequest request_;
  bool keep_alive_ = false;
  std::function<std::string()> events_;
  bool gzip_ = false;  ///< the reader takes gzip
  /// The stream's compressor: used by the event's worker only, never twice at once.
  std::unique_ptr<GzipStream> gzip_stream_;
  std::string out_;
  std::array<char, 4096> sink_{};
  std::size_t drained_ = 0;
};

}  // namespace

void HttpServer::Impl::accept() {
  acceptor.async_accept([this](beast::error_code ec, tcp::socket socket) {
    if (!acceptor.is_open()) return;
    if (ec) {
      // Out of descriptors, most likely: pause rather than spin.
      accept_pause.expires_after(std::chrono::milliseconds(50));
      accept_pause.async_wait([this](beast::error_code) { accept(); });
      return;
    }
    if (connections.load() < limits.max_connections) {
      std::make_shared<Session>(std::move(socket), *this)->read_head();
    }  // else the socket closes here: a flood costs its sender, not the view
    accept();
  });
}

HttpServer::HttpServer(const std::string& host, int port, HttpHandler handler, HttpLimits limits)
    : impl_(std::make_unique<Impl>(std::move(handler), limits)) {
  std::string name = host;
  if (name.starts_with("[") && name.ends_with("]")) name = name.substr(1, name.size() - 2);
  try {
    tcp::resolver resolver(impl_->ioc);
    const auto found = resolver.resolve(name, std::to_string(port), tcp::resolver::passive);
    const tcp::endpoint endpoint = found.begin()->endpoint();
    impl_->acceptor.open(endpoint.protocol());
    impl_->acceptor.set_option(asio::socket_base::reuse_address(true));
    impl_->acceptor.bind(endpoint);
    impl_->acceptor.listen(asio::socket_base::max_listen_connections);
  } catch (const std::exception& e) {
    throw std::runtime_error(fmt::format("cannot listen on {}:{}: {}", host, port, e.what()));
  }
  impl_->accept();
  impl_->loop = std::thread([this] { impl_->ioc.run(); });
}

HttpServer::~HttpServer() {
  asio::post(impl_->ioc, [this] {
    beast::error_code ec;
    impl_->acceptor.close(ec);
  });
  impl_->ioc.stop();
  impl_->loop.join();
  impl_->reads.stop();
  impl_->control.stop();
  impl_->reads.join();
  impl_->control.join();
}

int HttpServer::port() const {
  return impl_->acceptor.local_endpoint().port();
}

}  // namespace piezo::host::view
