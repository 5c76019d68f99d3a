// What the view does with a stranger's request, seen from outside as a
// client sees it: a Host it does not serve is refused on every path (DNS
// rebinding), an oversized body is refused before it is read, control
// needs the token, and every shipped page has unique element ids.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <vector>

#include "build_paths.hpp"
#include "view/live_feed.hpp"
#include "view/view_server.hpp"

namespace piezo::host::view {
namespace {

int port_of(const std::string& url) {
  return std::stoi(url.substr(url.rfind(':') + 1));
}

/// A view with control, a stop that answers, and lab-pc allowed.
class ViewGuard : public ::testing::Test {
 protected:
  ViewServer server{{"127.0.0.1:0", "", true, {"lab-pc"}},
                    nullptr,
                    {[](const nlohmann::json&) { return nlohmann::json::object(); }, {}, {}, {}}};
  httplib::Client client{"127.0.0.1", port_of(server.url())};
};

TEST_F(ViewGuard, OnlyTheNamesItServesAreAnswered) {
  const int port = port_of(server.url());
  for (const std::string host : {"127.0.0.1", "localhost", "lab-pc"}) {
    const auto r = client.Get("/api/runs", {{"Host", host + ":" + std::to_string(port)}});
    ASSERT_TRUE(r) << host;
    EXPECT_EQ(r->status, 200) << host;
  }
  for (const std::string path : {"/api/runs", "/api/live.json", "/runs", "/"}) {
    const auto r = client.Get(path, {{"Host", "evil.example:" + std::to_string(port)}});
    ASSERT_TRUE(r) << path;
    EXPECT_EQ(r->status, 403) << path;
    EXPECT_NE(r->body.find("evil.example"), std::string::npos) << r->body;
  }
}

TEST_F(ViewGuard, ControlNeedsTheTokenAndTakesSmallBodiesOnly) {
  const auto none = client.Post("/api/stop", "{}", "application/json");
  ASSERT_TRUE(none);
  EXPECT_EQ(none->status, 403);
  const auto wrong =
      client.Post("/api/stop", {{"X-Piezo-Token", server.token() + "0"}}, "{}", "application/json");
  ASSERT_TRUE(wrong);
  EXPECT_EQ(wrong->status, 403);
  const auto right =
      client.Post("/api/stop", {{"X-Piezo-Token", server.token()}}, "{}", "application/json");
  ASSERT_TRUE(right);
  EXPECT_EQ(right->status, 200) << right->body;
  const auto big = client.Post("/api/stop", {{"X-Piezo-Token", server.token()}},
                               std::string(70 * 1024, ' '), "application/json");
  ASSERT_TRUE(big);
  EXPECT_EQ(big->status, 413);
}

// 768 MiB announced, none sent: the refusal comes at once, the body unread
// (before, the server waited to read it all).
TEST_F(ViewGuard, AnOversizedBodyIsRefusedBeforeItIsRead) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port_of(server.url())));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  timeval wait{10, 0};  // far longer than a refusal takes; the body never comes
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &wait, sizeof wait);
  const std::string head =
      "POST /api/stop HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: text/plain\r\n"
      "Content-Length: 805306368\r\n\r\n";
  ASSERT_EQ(send(fd, head.data(), head.size(), 0), static_cast<ssize_t>(head.size()));
  char reply[64] = {};
  const ssize_t n = recv(fd, reply, sizeof reply - 1, 0);
  close(fd);
  ASSERT_GT(n, 0) << "no answer while the body was awaited";
  EXPECT_EQ(std::string(reply).substr(0, 12), "HTTP/1.1 413") << reply;
}

/// A raw connection that asks for the live stream and returns the status
/// line of its answer ("" when none came within 10 s); the socket stays open.
std::string open_live_page(int port, std::vector<int>& sockets) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) return "";
  sockets.push_back(fd);
  timeval wait{10, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &wait, sizeof wait);
  const std::string get = "GET /api/live HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n";
  if (send(fd, get.data(), get.size(), 0) != static_cast<ssize_t>(get.size())) return "";
  char reply[16] = {};
  const ssize_t n = recv(fd, reply, 12, 0);
  return n > 0 ? std::string(reply, static_cast<std::size_t>(n)) : "";
}

// Seventy live pages open at once: sixty-four are served, the rest told why
// (503), and the E-stop is still answered (before, eight open pages held
// every thread of the server and the E-stop waited for good).
TEST(ViewStreams, OpenLivePagesLeaveTheEstopAnswered) {
  LiveFeed feed(20.0, 0.3);
  int estops = 0;
  ViewServer server({"127.0.0.1:0", "", true, {}}, &feed,
                    {{},
                     [&estops](const nlohmann::json&) {
                       ++estops;
                       return nlohmann::json::object();
                     },
                     {},
                     {}});
  const int port = port_of(server.url());
  std::vector<int> sockets;
  int served = 0, refused = 0;
  for (int i = 0; i < 70; ++i) {
    const std::string status = open_live_page(port, sockets);
    served += status == "HTTP/1.1 200" ? 1 : 0;
    refused += status == "HTTP/1.1 503" ? 1 : 0;
  }
  EXPECT_EQ(served, 64);
  EXPECT_EQ(refused, 6);
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(10, 0);
  const auto r =
      client.Post("/api/estop", {{"X-Piezo-Token", server.token()}}, "{}", "application/json");
  ASSERT_TRUE(r) << "the E-stop was not answered";
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(estops, 1);
  for (int fd : sockets) close(fd);
}

TEST(ViewPages, EveryShippedPageHasUniqueIds) {
  int pages = 0;
  for (const auto& entry : std::filesystem::directory_iterator(
           std::filesystem::path(build_paths::source_dir) / "host/web")) {
    if (entry.path().extension() != ".html") continue;
    ++pages;
    std::ifstream in(entry.path());
    std::stringstream text;
    text << in.rdbuf();
    const std::string html = text.str();
    std::map<std::string, int> seen;
    const std::string attribute = " id=\"";
    for (auto at = html.find(attribute); at != std::string::npos; at = html.find(attribute, at)) {
      at += attribute.size();
      const std::string id = html.substr(at, html.find('"', at) - at);
      EXPECT_EQ(++seen[id], 1) << entry.path().filename() << ": id \"" << id << "\" twice";
    }
  }
  EXPECT_GE(pages, 3);
}

}  // namespace
}  // namespace piezo::host::view
