// rig-sim's Modbus TCP side: every client's frame is assembled in a buffer
// of its own from non-blocking reads (epoll), so a client that sends a byte
// and stalls, drips, or sends garbage costs the others nothing; idle
// connections cost nothing either (epoll reports only sockets with data).
// A frame whose header is not Modbus, or whose length does not fit its
// function, closes that client (a TCP byte stream cannot be resynchronised);
// so does a frame left unfinished past the frame timeout. Past the client
// cap a new connection is refused (closed at once); those held go on.

#include <arpa/inet.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/epoll.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <unordered_map>

#include "piezo/hal/modbus/mbap.hpp"
#include "piezo/hal/sim/modbus_rig_device.hpp"

namespace piezo::hal::sim {
namespace {

struct Client {
  std::array<std::uint8_t, 2 * modbus::kMaxTcpFrame> buffer{};
  std::size_t used = 0;
  TimeNs last_activity = 0;
  TimeNs frame_started = 0;  ///< when the unfinished frame's first byte came
};

/// Lets the process hold as many sockets as the cap asks for (the soft
/// limit is often 1024, below the hard one).
void raise_descriptor_limit(int wanted) {
  rlimit limit{};
  if (getrlimit(RLIMIT_NOFILE, &limit) != 0) return;
  const rlim_t need = static_cast<rlim_t>(wanted) + 64;
  if (limit.rlim_cur >= need) return;
  limit.rlim_cur = std::min(need, limit.rlim_max);
  setrlimit(RLIMIT_NOFILE, &limit);
}

}  // namespace

void ModbusRigDevice::serve_tcp(const std::string& host, int port) {
  const TcpLimits& limits = settings_.tcp;
  raise_descriptor_limit(limits.max_clients);
  modbus_t* ctx = modbus_new_tcp(host.c_str(), port);
  if (ctx == nullptr) throw std::runtime_error("rig-sim: bad address " + host);
  // A wave of connections must not overflow the kernel's queue of them.
  const int listener = modbus_tcp_listen(ctx, 1024);
  if (listener < 0) {
    const std::string why = modbus_strerror(errno);
    modbus_free(ctx);
    throw std::runtime_error(fmt::format("rig-sim: cannot listen on {}:{}: {}", host, port, why));
  }
  fcntl(listener, F_SETFL, fcntl(listener, F_GETFL) | O_NONBLOCK);
  const int poller = epoll_create1(EPOLL_CLOEXEC);
  if (poller < 0) throw std::runtime_error(std::string("rig-sim: epoll: ") + std::strerror(errno));
  const auto watch = [&](int fd) {
    epoll_event e{};
    e.events = EPOLLIN;
    e.data.fd = fd;
    return epoll_ctl(poller, EPOLL_CTL_ADD, fd, &e) == 0;
  };
  watch(listener);

  std::unordered_map<int, Client> clients;
  const auto drop = [&](int fd, std::string_view why) {
    if (!why.empty()) {
      ++tcp_stats_.refused_frames;
      fmt::print(stderr, "rig-sim: closed a client: {} ({} such so far)\n", why,
                 tcp_stats_.refused_frames);
    }
    epoll_ctl(poller, EPOLL_CTL_DEL, fd, nullptr);
    close(fd);
    clients.erase(fd);
  };
  const auto admit = [&](int fd, TimeNs now) {
    if (static_cast<int>(clients.size()) >= limits.max_clients) {
      // Refused, not room made: a quiet connection may be a run's, idle
      // between its requests or before its first.
      ++tcp_stats_.refused_clients;
      fmt::print(stderr, "rig-sim: refused a client: rig_sim.max_clients = {} held ({} so far)\n",
                 limits.max_clients, tcp_stats_.refused_clients);
      close(fd);
      return;
    }
    fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
    const int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    if (!watch(fd)) {
      close(fd);
      return;
    }
    clients[fd].last_activity = now;
  };
  const auto receive = [&](int fd, TimeNs now) {
    Client& c = clients.at(fd);
    const ssize_t n = ::recv(fd, c.buffer.data() + c.used, c.buffer.size() - c.used, 0);
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) {
      drop(fd, {});  // the client has gone
      return;
    }
    if (n < 0) return;
    if (c.used == 0) c.frame_started = now;
    c.used += static_cast<std::size_t>(n);
    c.last_activity = now;
    for (;;) {
      const modbus::RequestFrame frame =
          modbus::next_request(std::span<const std::uint8_t>(c.buffer.data(), c.used));
      if (frame.state == modbus::RequestFrame::State::malformed) {
        drop(fd, frame.why);
        return;
      }
      if (frame.state == modbus::RequestFrame::State::incomplete) break;
      modbus_set_socket(ctx, fd);
      answer(ctx, c.buffer.data(), static_cast<int>(frame.bytes));
      std::memmove(c.buffer.data(), c.buffer.data() + frame.bytes, c.used - frame.bytes);
      c.used -= frame.bytes;
      c.frame_started = now;
    }
  };
  const TimeNs frame_timeout = from_seconds(limits.frame_timeout_s);
  TimeNs next_sweep = 0;
  std::array<epoll_event, 64> events{};
  bool listening = true;
  for (;;) {
    if (listening && disconnected()) {
      // The disconnect fault: every client is dropped and nobody gets back in.
      while (!clients.empty()) drop(clients.begin()->first, {});
      epoll_ctl(poller, EPOLL_CTL_DEL, listener, nullptr);
      close(listener);
      listening = false;
    }
    const int ready = epoll_wait(poller, events.data(), static_cast<int>(events.size()), 20);
    if (ready < 0 && errno != EINTR) {
      throw std::runtime_error(std::string("rig-sim: epoll_wait: ") + std::strerror(errno));
    }
    idle();  // the watchdog runs whether requests come or not
    const TimeNs now = clock_.now();
    for (int i = 0; i < ready; ++i) {
      const int fd = events[static_cast<std::size_t>(i)].data.fd;
      if (fd == listener) {
        for (int client;
             listening && (client = accept4(listener, nullptr, nullptr, SOCK_CLOEXEC)) >= 0;) {
          admit(client, now);
        }
      } else if (clients.contains(fd)) {
        receive(fd, now);
      }
    }
    // A frame begun and not finished in time: a stalled or dripping client.
    if (now >= next_sweep) {
      next_sweep = now + from_seconds(0.05);
      std::vector<int> late;
      for (const auto& [fd, c] : clients) {
        if (c.used > 0 && now - c.frame_started > frame_timeout) late.push_back(fd);
      }
      for (int fd : late) drop(fd, "a frame unfinished past rig_sim.frame_timeout_s");
    }
  }
}

}  // namespace piezo::hal::sim
