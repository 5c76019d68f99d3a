#pragma once
// `piezo view` and `piezo run --view`: a small web server (HttpServer, on
// one event loop) for any browser on the PC. The live page follows the run
// under way (Server-Sent Events of what changed, decimated on the host; the
// tabs of one browser share one stream); the catalogue lists the runs of a
// directory, each with its plots, config and downloads. Read-only unless
// started with control: then stop, e-stop and move-to need the token
// printed at the start, and cross-site requests are refused. Only the
// Host names it serves are answered; bound beyond loopback, its data
// needs the token too.

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

namespace piezo::host::view {

class LiveFeed;
class HttpServer;
struct HttpRequest;
struct HttpReply;

struct ViewOptions {
  std::string listen = "127.0.0.1:8080";  ///< HOST:PORT (port 0: any free one)
  std::string runs_dir;                   ///< the catalogue's runs (empty: none)
  bool control = false;                   ///< allow stop and e-stop, with the token
  /// Host names served besides the bound address and the loopback names
  /// (--allow-host): any other Host header is refused, so a page whose name
  /// is rebound to this address (DNS rebinding) reads nothing.
  std::vector<std::string> allowed_hosts;
};

/// What control may do, called from the server's threads with the
/// request's JSON body; each returns a reply or throws with the reason.
/// An empty one is not available here.
struct ViewControls {
  using Action = std::function<nlohmann::json(const nlohmann::json& body)>;
  Action stop, estop, move;
  Action describe;  ///< the board's dictionary (GET /api/describe), for the page's move form
};

class ViewServer {
 public:
  /// Binds (throws with the address and the reason when it cannot) and serves
  /// from a thread of its own; `live` (may be null) outlives the server.
  ViewServer(const ViewOptions& options, const LiveFeed* live, ViewControls controls);
  ~ViewServer();
  ViewServer(const ViewServer&) = delete;
  ViewServer& operator=(const ViewServer&) = delete;

  /// http://HOST:PORT/ as bound.
  [[nodiscard]] const std::string& url() const { return url_; }
  /// The token: control's, and beyond loopback also the data's (empty when
  /// neither needs one).
  [[nodiscard]] const std::string& token() const { return token_; }
  /// What to tell the user: where it listens, and how control is guarded.
  [[nodiscard]] std::string banner() const;
  /// Once the live feed has finished (the run ended): lets every open live
  /// page take the run's end before the server goes, waiting at most
  /// `timeout` (a page that is gone or stuck costs no more).
  void let_pages_take_the_end(std::chrono::milliseconds timeout) const;

 private:
  /// Why a request is refused before its body is read (empty: served):
  /// a Host this view does not serve; for control, no --control, a wrong
  /// token or another site.
  [[nodiscard]] std::string refusal(const HttpRequest& req, int& status) const;
  [[nodiscard]] HttpReply serve(const HttpRequest& req);
  [[nodiscard]] HttpReply live_stream();

  ViewOptions options_;
  const LiveFeed* live_;
  ViewControls controls_;
  std::string url_, token_;
  /// Bound beyond loopback: the data (/api/, /files/) needs the token too.
  bool reads_need_token_ = false;
  std::shared_ptr<std::atomic<int>> streams_ = std::make_shared<std::atomic<int>>(0);
  std::unique_ptr<HttpServer> server_;  ///< last: stops first
};

}  // namespace piezo::host::view
