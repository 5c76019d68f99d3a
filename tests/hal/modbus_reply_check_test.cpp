// Our Modbus TCP client against a server that answers with the wrong
// header: another protocol id, another unit, another transaction, a length
// that is not the reply's. Each is `bad_reply`, never a reading; the same
// server's right reply is read as it is; the link comes back after each.

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <functional>
#include <thread>
#include <vector>

#include "piezo/hal/modbus/link.hpp"

namespace piezo::hal::modbus {
namespace {

using Reply = std::vector<std::uint8_t>;
/// Builds the answer to one request frame (read of 1 register at 0).
using Answer = std::function<Reply(const std::array<std::uint8_t, 12>&)>;

/// A one-thread Modbus TCP server on a loopback port of its own that
/// answers every request with `answer`, connection after connection.
class FakeServer {
 public:
  explicit FakeServer(Answer answer) : answer_(std::move(answer)) {
    listener_ = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    bind(listener_, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
    socklen_t len = sizeof addr;
    getsockname(listener_, reinterpret_cast<sockaddr*>(&addr), &len);
    port_ = ntohs(addr.sin_port);
    listen(listener_, 8);
    thread_ = std::thread([this] { serve(); });
  }
  ~FakeServer() {
    done_ = true;
    thread_.join();
    close(listener_);
  }
  [[nodiscard]] int port() const { return port_; }

 private:
  void serve() {
    std::vector<int> clients;
    while (!done_) {
      std::vector<pollfd> fds{{listener_, POLLIN, 0}};
      for (int c : clients) fds.push_back({c, POLLIN, 0});
      if (poll(fds.data(), fds.size(), 20) <= 0) continue;
      if (fds[0].revents & POLLIN) clients.push_back(accept(listener_, nullptr, nullptr));
      for (std::size_t i = 1; i < fds.size(); ++i) {
        if (!(fds[i].revents & POLLIN)) continue;
        std::array<std::uint8_t, 12> request{};
        if (recv(fds[i].fd, request.data(), request.size(), MSG_WAITALL) != 12) continue;
        const Reply reply = answer_(request);
        send(fds[i].fd, reply.data(), reply.size(), MSG_NOSIGNAL);
      }
    }
    for (int c : clients) close(c);
  }
  Answer answer_;
  int listener_ = -1;
  int port_ = 0;
  std::atomic<bool> done_{false};
  std::thread thread_;
};

/// The right reply to a read of one register: the value 0x1234.
Reply right(const std::array<std::uint8_t, 12>& q) {
  return {q[0], q[1], 0, 0, 0, 5, q[6], q[7], 2, 0x12, 0x34};
}

Status read_once(int port, std::uint16_t& value) {
  LinkSettings s;
  s.port = port;
  s.response_timeout_s = 0.2;
  Link link(s);
  return link.read(Function::holding, 1, 0, 1, &value);
}

TEST(ModbusReplyCheck, TheRightReplyIsRead) {
  FakeServer server(right);
  std::uint16_t value = 0;
  EXPECT_EQ(read_once(server.port(), value), Status::ok);
  EXPECT_EQ(value, 0x1234);
}

TEST(ModbusReplyCheck, AWrongHeaderIsABadReplyNotAReading) {
  struct Case {
    const char* name;
    std::function<void(Reply&)> spoil;
  };
  for (const Case& c : {Case{"protocol id 1", [](Reply& r) { r[3] = 1; }},
                        Case{"protocol id 0xFFFF", [](Reply& r) { r[2] = r[3] = 0xff; }},
                        Case{"unit id 2", [](Reply& r) { r[6] = 2; }},
                        Case{"transaction id off by one", [](Reply& r) { r[1] ^= 1; }},
                        Case{"MBAP length 6 for a 5-byte reply",
                             [](Reply& r) {
                               r[5] = 6;
                               r.push_back(0);
                             }},
                        Case{"MBAP length 4 for a 5-byte reply", [](Reply& r) {
                               r[5] = 4;
                               r.pop_back();
                             }}}) {
    SCOPED_TRACE(c.name);
    FakeServer server([&c](const auto& q) {
      Reply r = right(q);
      c.spoil(r);
      return r;
    });
    std::uint16_t value = 0;
    EXPECT_EQ(read_once(server.port(), value), Status::bad_reply);
    EXPECT_EQ(value, 0) << "nothing of a refused reply is taken";
  }
}

TEST(ModbusReplyCheck, AnExceptionReplyIsCountedAsSuch) {
  FakeServer server([](const auto& q) {
    return Reply{q[0], q[1], 0, 0, 0, 3, q[6], static_cast<std::uint8_t>(q[7] | 0x80), 2};
  });
  std::uint16_t value = 0;
  EXPECT_EQ(read_once(server.port(), value), Status::exception_reply);
}

}  // namespace
}  // namespace piezo::hal::modbus
