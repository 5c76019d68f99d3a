// rig-sim as a shared lab device meets clients it did not expect: a
// thousand idle connections, one that sends a byte and stalls, one that
// drips, frames that are not Modbus. A run against it goes on untouched,
// and rig-sim refuses what is malformed. The run's own figures (errors,
// status) and rig-sim's answers on the socket are what the tests look at.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <thread>

#include "../support/rig_sim.hpp"

namespace piezo::testing {
namespace {

/// A plain TCP connection to rig-sim, or -1.
int connect_to(int port) {
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

/// A read of 2 holding registers from address 0, unit 1, with the given
/// MBAP protocol id and length fields.
std::vector<std::uint8_t> read_request(std::uint16_t protocol = 0, std::uint16_t length = 6) {
  return {0x00,
          0x2a,
          static_cast<std::uint8_t>(protocol >> 8),
          static_cast<std::uint8_t>(protocol & 0xff),
          static_cast<std::uint8_t>(length >> 8),
          static_cast<std::uint8_t>(length & 0xff),
          0x01,
          0x03,
          0x00,
          0x00,
          0x00,
          0x02};
}

/// What comes back within `timeout_ms`: the bytes, "closed" when rig-sim
/// closed the connection, "" when nothing came.
std::string reply_to(int fd, const std::vector<std::uint8_t>& request, int timeout_ms = 2000) {
  if (send(fd, request.data(), request.size(), MSG_NOSIGNAL) !=
      static_cast<ssize_t>(request.size())) {
    return "closed";
  }
  pollfd p{fd, POLLIN, 0};
  if (poll(&p, 1, timeout_ms) <= 0) return "";
  std::array<char, 300> buffer{};
  const ssize_t n = recv(fd, buffer.data(), buffer.size(), 0);
  if (n <= 0) return "closed";
  return std::string(buffer.data(), static_cast<std::size_t>(n));
}

/// A 2 s run against rig-sim on `port`: its JSON summary.
nlohmann::json run_against(const fs::path& dir, int port) {
  const auto r = run_command(kPiezo + " run --config " + kConfig + " --duration 2 --json " +
                             "--set sensor.modbus.port=" + std::to_string(port) +
                             " --set drive.modbus-ao.port=" + std::to_string(port) + " --out " +
                             (dir / "run").string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return r.out.empty() ? nlohmann::json{} : nlohmann::json::parse(r.out);
}

void expect_clean(const nlohmann::json& j) {
  ASSERT_FALSE(j.is_null());
  EXPECT_EQ(j.at("status"), "completed") << j.dump();
  EXPECT_EQ(j.at("drive").at("errors").get<int>(), 0) << j.dump();
  EXPECT_EQ(j.at("sensor").at("errors").get<int>(), 0) << j.dump();
}

TEST_F(ModbusHil, MalformedFramesAreRefusedAndTheConnectionClosed) {
  auto rig = start_rig_sim();
  ASSERT_TRUE(wait_for_tcp(port));
  // A well-formed read is answered: header, function, byte count, 4 bytes.
  const int good = connect_to(port);
  const std::string answer = reply_to(good, read_request());
  ASSERT_EQ(answer.size(), 13u) << answer;
  EXPECT_EQ(answer[1], 0x2a);
  close(good);
  struct Bad {
    const char* name;
    std::vector<std::uint8_t> frame;
  };
  for (const Bad& bad :
       {Bad{"protocol id 1", read_request(1)}, Bad{"protocol id 0xFFFF", read_request(0xffff)},
        Bad{"MBAP length 7 for a 6-byte read", read_request(0, 7)},
        Bad{"MBAP length 5 for a 6-byte read", read_request(0, 5)},
        Bad{"MBAP length 0", read_request(0, 0)}}) {
    SCOPED_TRACE(bad.name);
    const int fd = connect_to(port);
    ASSERT_GE(fd, 0);
    EXPECT_EQ(reply_to(fd, bad.frame), "closed");
    close(fd);
  }
  EXPECT_EQ(read_ao_register(), 0) << "rig-sim still answers mbpoll";
}

TEST_F(ModbusHil, AThousandIdleClientsNeitherCrashNorSlowARun) {
  rlimit limit{};
  getrlimit(RLIMIT_NOFILE, &limit);
  limit.rlim_cur = std::min<rlim_t>(limit.rlim_max, 4096);
  setrlimit(RLIMIT_NOFILE, &limit);
  ASSERT_GE(limit.rlim_cur, 1200u) << "the test needs 1,100 sockets";
  auto rig = start_rig_sim();
  ASSERT_TRUE(wait_for_tcp(port));
  std::vector<int> idle;
  for (int i = 0; i < 1100; ++i) {
    const int fd = connect_to(port);
    if (fd >= 0) idle.push_back(fd);
  }
  EXPECT_EQ(idle.size(), 1100u);
  expect_clean(run_against(dir, port));
  for (int fd : idle) close(fd);
  // rig-sim is still there (it had aborted at its 1,024th socket).
  EXPECT_GE(read_ao_register(), 0);
}

TEST_F(ModbusHil, AStalledAndADrippingClientCostARunNothing) {
  auto rig = start_rig_sim();
  ASSERT_TRUE(wait_for_tcp(port));
  // One sends the first byte of a frame and holds the connection; the
  // other drips a valid frame a byte every 100 ms, again and again.
  const int stalled = connect_to(port);
  const std::uint8_t first = 0;
  ASSERT_EQ(send(stalled, &first, 1, MSG_NOSIGNAL), 1);
  std::atomic<bool> done{false};
  std::thread dripper([&] {
    while (!done) {
      const int fd = connect_to(port);
      for (std::uint8_t byte : read_request()) {
        if (done || send(fd, &byte, 1, MSG_NOSIGNAL) != 1) break;
        std::this_thread::sleep_for(100ms);
      }
      close(fd);
    }
  });
  expect_clean(run_against(dir, port));
  done = true;
  dripper.join();
  // The stalled client was closed once its frame was overdue.
  EXPECT_EQ(reply_to(stalled, {}, 100), "closed");
  close(stalled);
}

TEST_F(ModbusHil, PastItsClientCapANewConnectionIsRefusedAndTheHeldOnesServed) {
  auto rig = start_rig_sim({"--set", "rig_sim.max_clients=20"});
  ASSERT_TRUE(wait_for_tcp(port));
  std::vector<int> held;
  // Each served as it comes: rig-sim has then also seen the close of
  // wait_for_tcp's probe, which came before (else the probe still counts).
  for (int i = 0; i < 20; ++i) {
    held.push_back(connect_to(port));
    ASSERT_EQ(reply_to(held.back(), read_request()).size(), 13u) << "held " << i;
  }
  const int one_too_many = connect_to(port);  // the kernel accepts; rig-sim closes it
  EXPECT_EQ(reply_to(one_too_many, read_request()), "closed");
  close(one_too_many);
  EXPECT_EQ(reply_to(held.front(), read_request()).size(), 13u) << "the first held is served";
  EXPECT_EQ(reply_to(held.back(), read_request()).size(), 13u) << "and the last";
  for (int fd : held) close(fd);
}

}  // namespace
}  // namespace piezo::testing
