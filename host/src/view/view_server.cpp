#include "view_server.hpp"

#include <fmt/format.h>
#include <httplib.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>

#include "live_feed.hpp"
#include "run_catalogue.hpp"
#include "web_assets.hpp"

namespace piezo::host::view {
namespace {

constexpr std::size_t kColumns = 800;        // about one point pair per pixel of a plot
constexpr std::size_t kMaxBody = 64 * 1024;  // a control request's JSON needs a few bytes
// Each open live page holds a connection, and so a thread, for as long as
// it stays: the streams are capped well below the threads, so that Stop
// and E-stop find a free one (cpp-httplib's default pool has 8; eight open
// pages silenced the E-stop).
constexpr std::size_t kServerThreads = 64;
constexpr int kMaxStreams = 16;
constexpr auto kLivePeriod = std::chrono::milliseconds(250);

std::string random_token() {
  std::random_device rd;
  std::string token;
  for (int i = 0; i < 24; ++i) token += fmt::format("{:02x}", rd() & 0xffu);
  return token;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return {};
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// uPlot, installed by the project's set-up from the npm registry.
std::string vendor_dir() {
  if (const char* dir = std::getenv("PIEZO_UPLOT_DIR")) return dir;
  return PIEZO_UPLOT_DIR;
}

void send_json(httplib::Response& res, const nlohmann::json& j) {
  res.set_content(j.dump(), "application/json");
}

void refuse(httplib::Response& res, int status, const std::string& why) {
  res.status = status;
  send_json(res, {{"ok", false}, {"error", why}});
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

/// The name in a Host header, without its port ("[::1]:8080" -> "[::1]").
std::string host_name(const std::string& host) {
  if (host.starts_with("[")) return host.substr(0, host.find(']') + 1);
  return host.substr(0, host.rfind(':'));
}

}  // namespace

ViewServer::ViewServer(const ViewOptions& options, const LiveFeed* live, ViewControls controls)
    : options_(options),
      live_(live),
      controls_(std::move(controls)),
      server_(std::make_unique<httplib::Server>()) {
  const auto colon = options_.listen.rfind(':');
  if (colon == std::string::npos) {
    throw std::runtime_error(fmt::format(
        "--view/--listen: \"{}\" is not HOST:PORT, e.g. 127.0.0.1:8080", options_.listen));
  }
  const std::string host = options_.listen.substr(0, colon);
  int port = std::atoi(options_.listen.substr(colon + 1).c_str());
  reads_need_token_ =
      !host.starts_with("127.") && host != "localhost" && host != "[::1]" && host != "::1";
  if (options_.control || reads_need_token_) token_ = random_token();
  options_.allowed_hosts.insert(options_.allowed_hosts.end(),
                                {host, "localhost", "127.0.0.1", "[::1]"});
  server_->set_payload_max_length(kMaxBody);
  server_->new_task_queue = [] { return new httplib::ThreadPool(kServerThreads); };
  routes();
  const bool bound =
      port == 0 ? (port = server_->bind_to_any_port(host)) > 0 : server_->bind_to_port(host, port);
  if (!bound) {
    throw std::runtime_error(fmt::format("--view/--listen: cannot listen on {}", options_.listen));
  }
  url_ = fmt::format("http://{}:{}/", host, port);
  thread_ = std::thread([this] { server_->listen_after_bind(); });
}

ViewServer::~ViewServer() {
  server_->stop();
  if (thread_.joinable()) thread_.join();
}

std::string ViewServer::banner() const {
  std::string out =
      fmt::format("live view: {}{}", url_, token_.empty() ? "" : fmt::format("?token={}", token_));
  out += reads_need_token_ ? " (LISTENING BEYOND THIS MACHINE; its data needs the token"
                           : " (this machine only";
  out += options_.control ? "; control with the token)" : "; read-only)";
  return out;
}

std::string ViewServer::refusal(const httplib::Request& req, int& status) const {
  status = 403;
  const std::string host = host_name(req.get_header_value("Host"));
  if (std::find(options_.allowed_hosts.begin(), options_.allowed_hosts.end(), host) ==
      options_.allowed_hosts.end()) {
    return fmt::format("Host \"{}\" is not a name this view serves (--allow-host NAME adds one)",
                       host);
  }
  if (req.method != "POST") {
    const bool data = req.path.starts_with("/api/") || req.path.starts_with("/files/");
    if (data && reads_need_token_) {
      const std::string given = req.has_header("X-Piezo-Token")
                                    ? req.get_header_value("X-Piezo-Token")
                                    : req.get_param_value("token");
      if (!same_secret(given, token_)) {
        return "this view listens beyond this machine: its data needs the token (printed when "
               "the view started)";
      }
    }
    return {};
  }
  if (std::strtoull(req.get_header_value("Content-Length").c_str(), nullptr, 10) > kMaxBody) {
    status = 413;
    return fmt::format("a body of at most {} bytes", kMaxBody);
  }
  if (!options_.control) return "read-only view: start it with --control to allow this";
  if (!same_secret(req.get_header_value("X-Piezo-Token"), token_)) {
    return "missing or wrong token (printed when the view started)";
  }
  const std::string origin = req.get_header_value("Origin");
  const std::string site = req.get_header_value("Sec-Fetch-Site");
  if ((!origin.empty() && origin != "http://" + req.get_header_value("Host")) ||
      (!site.empty() && site != "same-origin" && site != "none")) {
    return "cross-site request refused";
  }
  return {};
}

void ViewServer::routes() {
  auto& s = *server_;
  // Checked before any body is read: a stranger's request costs nothing.
  s.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    int status = 0;
    const std::string why = refusal(req, status);
    if (why.empty()) return httplib::Server::HandlerResponse::Unhandled;
    res.set_header("Connection", "close");  // its unread body is not a next request
    refuse(res, status, why);
    return httplib::Server::HandlerResponse::Handled;
  });
  s.Get("/", [this](const httplib::Request&, httplib::Response& res) {
    if (live_ == nullptr) {
      res.set_redirect("/runs");
      return;
    }
    res.set_content(std::string(kLiveHtml), "text/html; charset=utf-8");
  });
  s.Get("/runs", [](const httplib::Request&, httplib::Response& res) {
    res.set_content(std::string(kRunsHtml), "text/html; charset=utf-8");
  });
  s.Get(R"(/run/([^/]+))", [](const httplib::Request&, httplib::Response& res) {
    res.set_content(std::string(kRunHtml), "text/html; charset=utf-8");
  });
  s.Get(R"(/vendor/(uPlot\.iife\.min\.js|uPlot\.min\.css))",
        [](const httplib::Request& req, httplib::Response& res) {
          const std::string name = req.matches[1];
          const std::string body = read_file(vendor_dir() + "/" + name);
          if (body.empty()) {
            refuse(res, 404,
                   fmt::format("{} not found in {} (scripts/setup.sh installs uPlot from the npm "
                               "registry; PIEZO_UPLOT_DIR overrides)",
                               name, vendor_dir()));
            return;
          }
          res.set_content(body, name.ends_with(".js") ? "text/javascript" : "text/css");
        });

  s.Get("/api/live.json", [this](const httplib::Request&, httplib::Response& res) {
    if (live_ == nullptr) return refuse(res, 404, "no run under way in this view");
    send_json(res, live_->snapshot(kColumns));
  });
  s.Get("/api/live", [this](const httplib::Request&, httplib::Response& res) {
    if (live_ == nullptr) return refuse(res, 404, "no run under way in this view");
    if (streams_.fetch_add(1) >= kMaxStreams) {
      streams_.fetch_sub(1);
      return refuse(res, 503,
                    fmt::format("{} live pages are open already: close one (each holds a "
                                "connection of this view; /api/live.json answers without one)",
                                kMaxStreams));
    }
    res.set_header("Cache-Control", "no-cache");
    res.set_chunked_content_provider(
        "text/event-stream",
        [this](std::size_t, httplib::DataSink& sink) {
          const std::string event = "data: " + live_->snapshot(kColumns).dump() + "\n\n";
          if (!sink.write(event.data(), event.size())) return false;
          std::this_thread::sleep_for(kLivePeriod);
          return true;
        },
        [this](bool) { streams_.fetch_sub(1); });
  });
  s.Get("/api/runs", [this](const httplib::Request&, httplib::Response& res) {
    send_json(res, {{"runs_dir", options_.runs_dir},
                    {"runs", options_.runs_dir.empty() ? nlohmann::json::array()
                                                       : list_runs(options_.runs_dir)}});
  });
  s.Get(R"(/api/run/([^/]+))", [this](const httplib::Request& req, httplib::Response& res) {
    const auto dir =
        options_.runs_dir.empty() ? std::nullopt : run_path(options_.runs_dir, req.matches[1]);
    if (!dir) return refuse(res, 404, fmt::format("no run \"{}\"", std::string(req.matches[1])));
    try {
      send_json(res, run_plots(*dir, kColumns));
    } catch (const std::exception& e) {
      refuse(res, 500, e.what());
    }
  });
  s.Get(R"(/files/([^/]+)/(run\.h5|config\.toml))",
        [this](const httplib::Request& req, httplib::Response& res) {
          const auto dir = options_.runs_dir.empty() ? std::nullopt
                                                     : run_path(options_.runs_dir, req.matches[1]);
          if (!dir) return refuse(res, 404, "no such run");
          const std::string name = req.matches[2];
          res.set_header("Content-Disposition", "attachment; filename=\"" + name + "\"");
          res.set_content(read_file((*dir / name).string()),
                          name.ends_with(".h5") ? "application/x-hdf5" : "text/plain");
        });

  // Control: POST only, with the token in a header (which a cross-site form
  // cannot send, and a cross-site script only after a preflight this server
  // never answers), from this page's own origin: refusal() checked it all
  // before the body was read.
  const auto guarded = [this](const ViewControls::Action& action, const char* what) {
    return [action, what](const httplib::Request& req, httplib::Response& res) {
      if (!action) return refuse(res, 404, fmt::format("{}: not available here", what));
      try {
        const nlohmann::json body =
            req.body.empty() ? nlohmann::json::object() : nlohmann::json::parse(req.body);
        send_json(res, {{"ok", true}, {"sent", what}, {"reply", action(body)}});
      } catch (const std::exception& e) {
        refuse(res, 409, fmt::format("{}: {}", what, e.what()));
      }
    };
  };
  s.Post("/api/stop", guarded(controls_.stop, "stop"));
  s.Post("/api/estop", guarded(controls_.estop, "estop"));
  s.Post("/api/move", guarded(controls_.move, "move"));
}

}  // namespace piezo::host::view
