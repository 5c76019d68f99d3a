#include "view_server.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>

#include "http_server.hpp"
#include "live_feed.hpp"
#include "piezo/config/read_file.hpp"
#include "run_catalogue.hpp"
#include "web_assets.hpp"

namespace piezo::host::view {
namespace {

constexpr std::size_t kColumns = 800;        // about one point pair per pixel of a plot
constexpr std::size_t kMaxBody = 64 * 1024;  // a control request's JSON needs a few bytes
// An open live page costs a socket and a few kB/s, never a thread; the cap
// bounds what the host's CPU spends on viewers (a browser's tabs share one).
constexpr int kMaxStreams = 64;

std::string random_token() {
  std::random_device rd;
  std::string token;
  for (int i = 0; i < 24; ++i) token += fmt::format("{:02x}", rd() & 0xffu);
  return token;
}

/// uPlot, installed by the project's set-up from the npm registry.
std::string vendor_dir() {
  if (const char* dir = std::getenv("PIEZO_UPLOT_DIR")) return dir;
  return PIEZO_UPLOT_DIR;
}

HttpReply json_reply(const nlohmann::json& j) {
  return {200, "application/json", j.dump(), {}, {}};
}

HttpReply refused(int status, const std::string& why) {
  return {status, "application/json", nlohmann::json{{"ok", false}, {"error", why}}.dump(), {}, {}};
}

HttpReply page(std::string_view text, const char* type = "text/html; charset=utf-8") {
  return {200, type, std::string(text), {}, {}};
}

/// Compares in a time that does not depend on where they differ: the token
/// is not guessed byte by byte from response times.
bool same_secret(std::string_view given, std::string_view secret) {
  unsigned char diff = given.size() == secret.size() ? 0 : 1;
  for (std::size_t i = 0; i < secret.size(); ++i) {
    diff |= static_cast<unsigned char>(secret[i] ^ (i < given.size() ? given[i] : 0));
  }
  return diff == 0;
}

/// NAME of PREFIX + NAME, a single path segment (empty when the path is not so).
std::string name_after(const std::string& path, std::string_view prefix) {
  if (!path.starts_with(prefix)) return {};
  const std::string name = path.substr(prefix.size());
  return name.find('/') == std::string::npos ? name : std::string{};
}

/// /files/RUN/FILE with FILE run.h5 or config.toml: {RUN, FILE}, else empty.
std::pair<std::string, std::string> run_file(const std::string& path) {
  const std::string rest = path.starts_with("/files/") ? path.substr(7) : std::string{};
  const auto slash = rest.find('/');
  if (slash == std::string::npos || slash == 0) return {};
  const std::string file = rest.substr(slash + 1);
  if (file != "run.h5" && file != "config.toml") return {};
  return {rest.substr(0, slash), file};
}

/// The name in a Host header, without its port ("[::1]:8080" -> "[::1]").
std::string host_name(const std::string& host) {
  if (host.starts_with("[")) return host.substr(0, host.find(']') + 1);
  return host.substr(0, host.rfind(':'));
}

}  // namespace

ViewServer::ViewServer(const ViewOptions& options, const LiveFeed* live, ViewControls controls)
    : options_(options), live_(live), controls_(std::move(controls)) {
  const auto colon = options_.listen.rfind(':');
  if (colon == std::string::npos) {
    throw std::runtime_error(fmt::format(
        "--view/--listen: \"{}\" is not HOST:PORT, e.g. 127.0.0.1:8080", options_.listen));
  }
  const std::string host = options_.listen.substr(0, colon);
  const int port = std::atoi(options_.listen.substr(colon + 1).c_str());
  reads_need_token_ =
      !host.starts_with("127.") && host != "localhost" && host != "[::1]" && host != "::1";
  if (options_.control || reads_need_token_) token_ = random_token();
  options_.allowed_hosts.insert(options_.allowed_hosts.end(),
                                {host, "localhost", "127.0.0.1", "[::1]"});
  HttpHandler handler{[this](const HttpRequest& head) -> std::optional<HttpReply> {
                        int status = 0;
                        const std::string why = refusal(head, status);
                        if (why.empty()) return std::nullopt;
                        return refused(status, why);
                      },
                      [](const HttpRequest& req) { return req.method == "POST"; },
                      [this](const HttpRequest& req) { return serve(req); }};
  HttpLimits limits;
  limits.max_body = kMaxBody;
  try {
    server_ = std::make_unique<HttpServer>(host, port, std::move(handler), limits);
  } catch (const std::exception& e) {
    throw std::runtime_error(fmt::format("--view/--listen: {}", e.what()));
  }
  url_ = fmt::format("http://{}:{}/", host, server_->port());
}

ViewServer::~ViewServer() = default;

std::string ViewServer::banner() const {
  std::string out =
      fmt::format("live view: {}{}", url_, token_.empty() ? "" : fmt::format("?token={}", token_));
  out += reads_need_token_ ? " (LISTENING BEYOND THIS MACHINE; its data needs the token"
                           : " (this machine only";
  out += options_.control ? "; control with the token)" : "; read-only)";
  return out;
}

std::string ViewServer::refusal(const HttpRequest& req, int& status) const {
  status = 403;
  const std::string host = host_name(req.header("host"));
  if (std::find(options_.allowed_hosts.begin(), options_.allowed_hosts.end(), host) ==
      options_.allowed_hosts.end()) {
    return fmt::format("Host \"{}\" is not a name this view serves (--allow-host NAME adds one)",
                       host);
  }
  if (req.method != "POST") {
    const bool data = req.path.starts_with("/api/") || req.path.starts_with("/files/");
    if (data && reads_need_token_) {
      const std::string given =
          req.headers.contains("x-piezo-token") ? req.header("x-piezo-token") : req.param("token");
      if (!same_secret(given, token_)) {
        return "this view listens beyond this machine: its data needs the token (printed when "
               "the view started)";
      }
    }
    return {};
  }
  if (std::strtoull(req.header("content-length").c_str(), nullptr, 10) > kMaxBody) {
    status = 413;
    return fmt::format("a body of at most {} bytes", kMaxBody);
  }
  if (!options_.control) return "read-only view: start it with --control to allow this";
  if (!same_secret(req.header("x-piezo-token"), token_)) {
    return "missing or wrong token (printed when the view started)";
  }
  const std::string origin = req.header("origin");
  const std::string site = req.header("sec-fetch-site");
  if ((!origin.empty() && origin != "http://" + req.header("host")) ||
      (!site.empty() && site != "same-origin" && site != "none")) {
    return "cross-site request refused";
  }
  return {};
}

HttpReply ViewServer::serve(const HttpRequest& req) {
  const std::string& path = req.path;
  if (req.method == "POST") {
    // Control: POST only, with the token in a header (which a cross-site
    // form cannot send, and a cross-site script only after a preflight this
    // server never answers), from this page's own origin: refusal() checked
    // it all before the body was read.
    const auto action = [&](const ViewControls::Action& act, const std::string& what) {
      if (!act) return refused(404, fmt::format("{}: not available here", what));
      try {
        const nlohmann::json body =
            req.body.empty() ? nlohmann::json::object() : nlohmann::json::parse(req.body);
        return json_reply({{"ok", true}, {"sent", what}, {"reply", act(body)}});
      } catch (const std::exception& e) {
        return refused(409, fmt::format("{}: {}", what, e.what()));
      }
    };
    // Each action is named by its path: /api/stop is "stop".
    const std::string what = path.substr(path.rfind('/') + 1);
    if (path == "/api/stop") return action(controls_.stop, what);
    if (path == "/api/estop") return action(controls_.estop, what);
    if (path == "/api/move") return action(controls_.move, what);
    return refused(404, fmt::format("no POST {}", path));
  }
  if (req.method != "GET") return refused(405, "GET or POST only");
  if (path == "/") {
    if (live_ != nullptr) return page(kLiveHtml);
    HttpReply r{302, "text/plain", "", {{"Location", "/runs"}}, {}};
    return r;
  }
  if (path == "/api/describe") {
    if (!controls_.describe) return refused(404, "describe: no board here");
    return json_reply(controls_.describe({}));
  }
  if (path == "/runs") return page(kRunsHtml);
  if (!name_after(path, "/run/").empty()) return page(kRunHtml);
  if (path == "/live-window.js") return page(kLiveWindowJs, "text/javascript");
  if (path == "/live-worker.js") return page(kLiveWorkerJs, "text/javascript");
  if (path == "/move-form.js") return page(kMoveFormJs, "text/javascript");
  if (path == "/vendor/uPlot.iife.min.js" || path == "/vendor/uPlot.min.css") {
    const std::string name = path.substr(path.rfind('/') + 1);
    auto body = read_file(vendor_dir() + "/" + name);
    if (!body || body->empty()) {
      return refused(404, fmt::format("{} not found in {} (scripts/setup.sh installs uPlot from "
                                      "the npm registry; PIEZO_UPLOT_DIR overrides)",
                                      name, vendor_dir()));
    }
    return {200, name.ends_with(".js") ? "text/javascript" : "text/css", std::move(*body), {}, {}};
  }
  if (path == "/api/live.json") {
    if (live_ == nullptr) return refused(404, "no run under way in this view");
    nlohmann::json snapshot = live_->snapshot();
    snapshot["pages"] = streams_->load();
    return json_reply(snapshot);
  }
  if (path == "/api/live") return live_stream();
  if (path == "/api/runs") {
    return json_reply({{"runs_dir", options_.runs_dir},
                       {"runs", options_.runs_dir.empty() ? nlohmann::json::array()
                                                          : list_runs(options_.runs_dir)}});
  }
  if (const std::string run = name_after(path, "/api/run/"); !run.empty()) {
    const auto dir = options_.runs_dir.empty() ? std::nullopt : run_path(options_.runs_dir, run);
    if (!dir) return refused(404, fmt::format("no run \"{}\"", run));
    try {
      return json_reply(run_plots(*dir, kColumns));
    } catch (const std::exception& e) {
      return refused(500, e.what());
    }
  }
  if (const auto [run, name] = run_file(path); !run.empty()) {
    const auto dir = options_.runs_dir.empty() ? std::nullopt : run_path(options_.runs_dir, run);
    if (!dir) return refused(404, "no such run");
    auto body = read_file(*dir / name);
    if (!body) return refused(404, fmt::format("no file {} in run {}", name, run));
    return {200,
            name.ends_with(".h5") ? "application/x-hdf5" : "text/plain",
            std::move(*body),
            {{"Content-Disposition", "attachment; filename=\"" + name + "\""}},
            {}};
  }
  return refused(404, fmt::format("nothing at {}", path));
}

void ViewServer::let_pages_take_the_end(std::chrono::milliseconds timeout) const {
  if (live_ == nullptr) return;
  (void)live_->wait_until_pages_have_the_end([this] { return streams_->load(); }, timeout);
}

HttpReply ViewServer::live_stream() {
  if (live_ == nullptr) return refused(404, "no run under way in this view");
  if (streams_->fetch_add(1) >= kMaxStreams) {
    streams_->fetch_sub(1);
    return refused(503, fmt::format("{} live pages are open already: close one (the tabs of one "
                                    "browser share a stream; /api/live.json answers without one)",
                                    kMaxStreams));
  }
  // The page's place in the feed, and the count of open pages, go with its
  // stream: both end when the stream's function is destroyed.
  const std::shared_ptr<void> open(nullptr, [streams = streams_](void*) { streams->fetch_sub(1); });
  return {200, "text/event-stream", "", {}, [this, open, cursor = LiveCursor{}]() mutable {
            nlohmann::json event = live_->changes(cursor);
            event["pages"] = streams_->load();
            return event.dump();
          }};
}

}  // namespace piezo::host::view
