#include "daemon.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <filesystem>
#include <random>
#include <zmq_addon.hpp>

#include "calibration.hpp"
#include "daemon_run.hpp"
#include "piezo/config/config_error.hpp"
#include "piezo/firmware/wire_keys.hpp"
#include "piezo/protocol/endpoints.hpp"
#include "piezo/protocol/message.hpp"

namespace piezo::daemon {
namespace {

using nlohmann::json;
using protocol::ProtocolError;
namespace code = protocol::code;
using Clock = std::chrono::steady_clock;

constexpr auto kPollPeriod = std::chrono::milliseconds(2);
constexpr auto kHealthPeriod = std::chrono::milliseconds(250);

}  // namespace

namespace {

/// A board start's identity: 64 random bits as hex, unlike any earlier
/// start's (a restart on the same port is told apart from the board before).
std::string new_board_id() {
  std::random_device entropy;
  const std::uint64_t bits = (std::uint64_t{entropy()} << 32U) | entropy();
  return fmt::format("{:016x}", bits);
}

/// Where an axis keeps its calibration: the board's file, or on a board of
/// several axes that file with the axis's name before its extension
/// ("calibration.json": "calibration.theta.json").
std::string calibration_file_of(const std::string& file, const std::string& axis, bool several) {
  if (file.empty() || !several) return file;
  const std::filesystem::path p(file);
  return (p.parent_path() / (p.stem().string() + "." + axis + p.extension().string())).string();
}

}  // namespace

Daemon::Daemon(const config::BoardConfig& board, zmq::context_t& context, const std::string& listen,
               std::ostream& log)
    : Daemon(board, config::build_rig(board), context, listen, log) {}

Daemon::Daemon(const config::BoardConfig& board, config::Rig rig, zmq::context_t& context,
               const std::string& listen, std::ostream& log)
    : board_(board),
      board_id_(new_board_id()),
      log_(log),
      rig_(std::move(rig)),
      context_(context),
      commands_(context, zmq::socket_type::router),
      stream_(context, zmq::socket_type::pub),
      command_endpoint_(listen.empty() ? board.daemon.listen : listen),
      // recorder_s of a run of every axis: a group move records each axis's samples.
      samples_(board.daemon.recorder_s,
               board_.drive_rate_hz * static_cast<double>(board_.axes.size()),
               board_.sensor_rate_hz * static_cast<double>(board_.axes.size()),
               board.daemon.spill_file, board.daemon.fetch_samples_per_s, stream_),
      command_table_(command_table()) {
  for (std::size_t i = 0; i < board_.axes.size(); ++i) {
    axes_.push_back(std::make_unique<ServedAxis>(
        i, board_.axes[i], rig_.axes.at(i),
        calibration_file_of(board_.daemon.calibration_file, board_.axes[i].name,
                            board_.axes.size() > 1)));
  }
  try {
    stream_endpoint_ = protocol::stream_endpoint(command_endpoint_);
  } catch (const std::invalid_argument& e) {
    throw config::ConfigError(listen.empty() ? board.source : "--listen", "piezod.listen",
                              e.what());
  }
  bind_sockets();
  for (const auto& axis : axes_) {
    load_calibration_file(*axis);
    // The axis's own waveform's step table, before any client asks for a
    // move: a move at its [drive] costs the network thread nothing.
    const auto& d0 = axis->config.model.drive;
    (void)axis->planner.steps(d0.V0, d0.f, d0.D());
  }
  last_health_ = Clock::now();
  std::vector<hal::DisplacementSensor*> sensors;
  for (const auto& axis : axes_) sensors.push_back(axis->rig.sensor);
  // Not on the simulated rig's virtual clock: its time passes only as the
  // board reads, so readings at rest would shift every run's time origin by
  // however many came before it, and its runs repeat exactly.
  idle_ = std::make_unique<IdleReader>(*rig_.clock, std::move(sensors),
                                       board_.virtual_clock() ? 0.0 : board_.daemon.idle_rate_hz,
                                       [this] { advance_simulated_rig(); });
  std::string devices;
  for (const auto& axis : axes_) {
    devices +=
        fmt::format("{}axis {}: drive {}, sensor {}", devices.empty() ? "" : "; ", axis->name(),
                    axis->config.drive.backend(), axis->config.sensor.backend());
  }
  log_event(fmt::format("listening: commands {}, stream {}; {}; lines {}; board id {}",
                        command_endpoint_, stream_endpoint_, devices, board_.lines.backend(),
                        board_id_));
}

Daemon::~Daemon() = default;

void Daemon::bind_sockets() {
  const bool network = protocol::is_network_endpoint(command_endpoint_);
  const auto& d = board_.daemon;
  if (network && d.secret_key_file.empty() && !d.insecure) {
    throw std::runtime_error(fmt::format(
        "listen = \"{}\" is a network address: set piezod.secret_key_file and "
        "piezod.authorized_keys_file (CURVE, keys from `piezod keygen`), or bind to 127.0.0.1; "
        "plain text on a network needs --insecure",
        command_endpoint_));
  }
  if (!d.secret_key_file.empty()) {
    const std::string secret = read_key(d.secret_key_file, "secret-key");
    if (d.authorized_keys_file.empty()) {
      throw std::runtime_error(
          "piezod.authorized_keys_file: missing (CURVE needs the clients' "
          "public keys)");
    }
    zap_ =
        std::make_unique<ZapHandler>(context_, read_authorized_keys(d.authorized_keys_file), log_);
    for (auto* s : {&commands_, &stream_}) {
      s->set(zmq::sockopt::curve_server, 1);
      s->set(zmq::sockopt::curve_secretkey, secret);
      s->set(zmq::sockopt::zap_domain, "piezod");
    }
    log_event("CURVE on: only authorized clients are admitted");
  } else if (network) {
    log_event("WARNING: --insecure: plain text on a network address, any peer may connect");
  }
  commands_.set(zmq::sockopt::router_mandatory, 0);
  // A client that gave up on a request closes its socket (so the request
  // never leaves it) and opens another under the same routing id: the new
  // connection takes the old one's place, and a controller stays one.
  commands_.set(zmq::sockopt::router_handover, 1);
  // Larger than the largest command, so an oversized one is read and
  // answered too_large instead of costing its sender its connection and
  // the replies in flight on it.
  commands_.set(zmq::sockopt::maxmsgsize, static_cast<std::int64_t>(protocol::kMaxTransportBytes));
  commands_.set(zmq::sockopt::linger, 0);
  // Replies a client does not read wait in its queue up to this many; then
  // they are dropped, so one that never reads cannot fill the board's memory.
  commands_.set(zmq::sockopt::sndhwm, 64);
  stream_.set(zmq::sockopt::sndhwm, 100'000);
  stream_.set(zmq::sockopt::linger, 0);
  if (protocol::is_ipv6_endpoint(command_endpoint_)) {
    commands_.set(zmq::sockopt::ipv6, 1);
    stream_.set(zmq::sockopt::ipv6, 1);
  }
  try {
    commands_.bind(protocol::loopback_literal(command_endpoint_));
    stream_.bind(protocol::loopback_literal(stream_endpoint_));
  } catch (const zmq::error_t& e) {
    throw std::runtime_error(fmt::format("piezod.listen: cannot listen on {} / {}: {}",
                                         command_endpoint_, stream_endpoint_, e.what()));
  }
}

void Daemon::load_calibration_file(ServedAxis& axis) {
  if (axis.calibration_file.empty()) return;
  // A file that cannot be used leaves the axis uncalibrated (moves use
  // the model), said in the log; it is replaced by the next calibration.
  const config::DriveSettings& drive = axis.config.drive;
  try {
    axis.calibration =
        load_calibration(axis.calibration_file,
                         {drive.limits.V_max, firmware::max_drive_frequency(board_.drive_rate_hz)});
    if (axis.calibration) {
      log_event(fmt::format("calibration of {} loaded from {}", axis.calibration->created,
                            axis.calibration_file));
    }
  } catch (const std::exception& e) {
    log_event(fmt::format("calibration not loaded: {}", e.what()));
  }
}

ServedAxis& Daemon::axis_of(const json& args, std::string_view cmd) {
  const auto it = args.find(wire_key::axis);
  if (it == args.end() || it->is_null()) {
    if (axes_.size() == 1) return *axes_.front();
    throw ProtocolError(code::bad_argument, wire_key::axis,
                        fmt::format("{}: axis: required on a board of several axes (allowed: {})",
                                    cmd, axis_names()));
  }
  const std::string name = it->is_string() ? it->get<std::string>() : protocol::wire::shown(*it);
  for (const auto& a : axes_) {
    if (it->is_string() && a->name() == name) return *a;
  }
  throw ProtocolError(code::bad_argument, wire_key::axis,
                      fmt::format("{}: axis: {} is not an axis of this board (allowed: {})", cmd,
                                  it->is_string() ? "\"" + name + "\"" : name, axis_names()));
}

std::string Daemon::axis_names() const {
  std::string out;
  for (const auto& a : axes_) out += (out.empty() ? "" : ", ") + a->name();
  return out;
}

void Daemon::log_event(const std::string& line) {
  log_ << fmt::format("piezod [{:.6f}] {}\n", hal::to_seconds(rig_.clock->now()), line)
       << std::flush;
}

bool Daemon::drive_loop_progressing() {
  const auto now = Clock::now();
  const std::uint64_t cycles = running() ? run_->runner->drive_health().cycles.load() : 0;
  if (!running() || cycles != last_drive_cycles_ || board_.virtual_clock()) {
    last_drive_cycles_ = cycles;
    last_drive_progress_ = now;
    return true;
  }
  return now - last_drive_progress_ < std::chrono::seconds(1);
}

void Daemon::serve(const std::atomic<bool>& stop, const std::function<void()>& alive) {
  bool stopping = false;
  while (true) {
    if (stop.load() && !stopping) {
      stopping = true;
      if (running()) {
        log_event("shutting down: stopping the run first");
        run_->runner->request_stop();
      }
    }
    if (stopping && !running()) break;
    poll_once();
    if (alive && drive_loop_progressing()) alive();
  }
  log_event("stopped");
}

void Daemon::poll_once() {
  std::array<zmq::pollitem_t, 2> items{
      zmq::pollitem_t{commands_.handle(), 0, ZMQ_POLLIN, 0},
      zmq::pollitem_t{zap_ ? zap_->socket().handle() : nullptr, 0, ZMQ_POLLIN, 0}};
  try {
    zmq::poll(items.data(), zap_ ? 2 : 1, kPollPeriod);
  } catch (const zmq::error_t& e) {
    if (e.num() != EINTR) throw;
    return;  // a signal: serve() looks at the stop flag
  }
  if (zap_ && (items[1].revents & ZMQ_POLLIN) != 0) zap_->handle();
  if ((items[0].revents & ZMQ_POLLIN) != 0) {
    for (int i = 0; i < 64; ++i) {
      std::vector<zmq::message_t> frames;
      if (!zmq::recv_multipart(commands_, std::back_inserter(frames), zmq::recv_flags::dontwait)) {
        break;
      }
      on_command(frames);
    }
  }
  check_lease_on_wall_clock();
  take_idle_readings();
  pump_samples();
  if (run_ && !run_->finished && run_->runner->finished()) finish_run();
  if (Clock::now() - last_health_ >= kHealthPeriod) {
    publish_health();
    last_health_ = Clock::now();
  }
}

void Daemon::on_command(std::vector<zmq::message_t>& frames) {
  // [routing id, body] from a DEALER; [routing id, "", body] from a REQ.
  if (frames.size() < 2) return;
  const std::string client = frames.front().to_string();
  const bool req_envelope = frames.size() == 3 && frames[1].size() == 0;
  std::optional<std::uint64_t> id;
  std::string reply;
  try {
    if (frames.size() != (req_envelope ? 3u : 2u)) {
      throw ProtocolError(code::malformed, "", "a request is one frame");
    }
    const auto request = protocol::decode_request(frames.back().to_string_view(), id);
    reply = protocol::encode_reply(
        request.id, command_table_.dispatch(client, request.cmd, request.args, run_state_));
  } catch (const ProtocolError& e) {
    reply = protocol::encode_error(id, {e.code(), e.key(), e.what()});
  } catch (const std::exception& e) {
    // A failure of the daemon's own: the client hears it, the daemon goes on.
    reply = protocol::encode_error(id, {code::internal, "", e.what()});
    log_event(fmt::format("internal error: {}", e.what()));
  }
  std::vector<zmq::const_buffer> out{zmq::buffer(client)};
  if (req_envelope) out.push_back(zmq::str_buffer(""));
  out.push_back(zmq::buffer(reply));
  (void)zmq::send_multipart(commands_, out, zmq::send_flags::dontwait);
}

protocol::ArgumentSpec Daemon::axis_spec() const {
  protocol::ArgumentSpec s;
  s.name = wire_key::axis;
  s.type = firmware::ArgumentType::choice;
  for (const config::AxisConfig& a : board_.axes) s.choices.push_back(a.name);
  s.required = board_.axes.size() > 1;
  if (!s.required) s.default_value = board_.axis().name;
  s.default_text = s.required ? "required (a board of several axes)" : "the board's one axis";
  s.doc = "which axis (`hello.axes`)";
  return s;
}

std::vector<protocol::ArgumentSpec> Daemon::stop_specs() const {
  protocol::ArgumentSpec axis = axis_spec();
  axis.required = false;
  axis.default_value = nullptr;
  axis.default_text = "every axis of the run";
  axis.doc = "stop this axis of the run alone (`hello.axes`); the others go on";
  protocol::ArgumentSpec now;
  now.name = wire_key::now;
  now.type = firmware::ArgumentType::flag;
  now.default_value = false;
  now.doc = "0 V on the next drive deadline instead of the ramp (an abort; nothing latches)";
  return {axis, now};
}

std::vector<protocol::ArgumentSpec> Daemon::move_to_specs() const {
  std::vector<protocol::ArgumentSpec> args = protocol::move_to_specs();
  // A group move names its axes and targets in `targets` instead.
  for (protocol::ArgumentSpec& a : args) {
    if (a.name != wire_key::target_rad) continue;
    a.required = false;
    a.default_text = "required, unless `targets` names the targets";
  }
  protocol::ArgumentSpec axis = axis_spec();
  if (axis.required) {
    axis.required = false;
    axis.default_text = "required, unless `targets` names the axes";
  }
  args.push_back(std::move(axis));
  protocol::ArgumentSpec targets;
  targets.name = wire_key::targets;
  targets.type = firmware::ArgumentType::map;
  targets.default_text = "none: one axis's move (`target_rad`, `axis`)";
  targets.doc =
      "a group move: {axis: target_rad, ...}, every axis started on one tick, each ending on "
      "its own; the other arguments hold for each";
  args.push_back(std::move(targets));
  return args;
}

CommandTable Daemon::command_table() {
  using C = Caller;
  using Args = const json&;
  using Who = const std::string&;
  // The commands that act on one axis take `axis` beside their own arguments.
  const auto on_axis = [this](std::vector<protocol::ArgumentSpec> args) {
    args.push_back(axis_spec());
    return args;
  };
  return CommandTable(
      {
          {"hello", C::anyone, {}, [this](Who, Args) { return json(hello()); }},
          {"describe",
           C::anyone,
           {},
           [this](Who, Args) {
             return protocol::describe(command_table_.specs(), hello().limits);
           }},
          {"status", C::anyone, {}, [this](Who c, Args) { return json(status(c)); }},
          {wire_key::clock,
           C::anyone,
           {},
           [this](Who, Args) { return json(protocol::ClockReply{rig_.clock->now()}); }},
          {protocol::ConfigureRequest::kCommand, C::controller,
           on_axis(protocol::specs_of<protocol::ConfigureRequest>()),
           [this](Who, Args a) { return configure(a); }},
          {protocol::StartRequest::kCommand, C::controller,
           protocol::specs_of<protocol::StartRequest>(),
           [this](Who c, Args a) {
             return start(c, protocol::decode<protocol::StartRequest>(a).lease_s);
           }},
          {protocol::StepRequest::kCommand, C::controller,
           on_axis(protocol::specs_of<protocol::StepRequest>()),
           [this](Who c, Args a) { return step(c, a); }},
          {protocol::MoveToRequest::kCommand, C::controller, move_to_specs(),
           [this](Who c, Args a) { return move_to(c, a); }},
          {protocol::ScanRequest::kCommand, C::controller, scan_specs(),
           [this](Who c, Args a) { return scan(c, a); }},
          {protocol::CalibrateRequest::kCommand, C::controller,
           on_axis(protocol::specs_of<protocol::CalibrateRequest>()),
           [this](Who c, Args a) { return calibrate(c, a); }},
          {"set_calibration", C::controller,
           on_axis({protocol::ArgumentSpec{
               std::string(wire_key::calibration),
               firmware::ArgumentType::map,
               "",
               {},
               "",
               {},
               true,
               nullptr,
               "required",
               "a calibration (docs/protocol.md, \"Calibration\"), or nil"}}),
           [this](Who c, Args a) { return set_calibration(c, a); }},
          {"zero", C::controller, on_axis({}), [this](Who c, Args a) { return set_zero(c, a); }},
          {"stop", C::controller, stop_specs(), [this](Who, Args a) { return stop_run(a); }},
          // Anyone may press it: it only ever makes the rig safer.
          {"estop", C::anyone, {}, [this](Who c, Args) { return estop(c); }},
          // Refused to everyone during a run; between runs nobody controls the rig.
          {"reset_fault", C::anyone, {}, [this](Who, Args) { return reset_fault(); }},
          {protocol::LeaseRequest::kCommand, C::controller,
           protocol::specs_of<protocol::LeaseRequest>(),
           [this](Who, Args a) { return renew_lease(a); }},
          {protocol::FetchRequest::kCommand, C::anyone,
           protocol::specs_of<protocol::FetchRequest>(),
           [this](Who c, Args a) {
             return samples_.fetch(c, a, running() && !run_state_.is_controller(c));
           }},
      },
      board_id_);
}

}  // namespace piezo::daemon
