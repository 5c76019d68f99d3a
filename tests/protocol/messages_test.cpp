// Every protocol message round-trips through its type and MessagePack, and
// a map that lacks a field is refused naming it (docs/protocol.md).

#include "piezo/protocol/messages.hpp"

#include <gtest/gtest.h>

#include <array>
#include <set>
#include <string>
#include <string_view>

#include "piezo/protocol/error.hpp"
#include "piezo/protocol/message.hpp"

namespace piezo::protocol {
namespace {

using nlohmann::json;

/// Encoded as the wire carries it (a MessagePack map), decoded back.
template <class T>
T over_the_wire(const T& m) {
  json j = m;
  return decode<T>(decode_map(encode_map(j)));
}

template <class T>
std::string refusal_key(const json& j) {
  try {
    (void)decode<T>(j);
  } catch (const ProtocolError& e) {
    return e.code() + " " + e.key();
  }
  return "accepted";
}

/// A calibration as the board measures it: one frequency, its derived figures.
CalibrationRecord a_calibration() {
  CalibrationRecord c;
  c.created = "2026-11-26T03:00:00Z";
  c.V0 = 80.0;
  c.D = 0.74955;
  c.r2_m = 0.062;
  c.steps_per_point = 8;
  c.rest_readings = CalibrationRecord::RestReadings{10, 16};
  c.step_fractions = {0.25, 0.5, 1.0};
  c.noise_m = 5e-7;
  c.rad_per_V = 3e-5;
  c.frequencies = {{10.0, {1e-5, 4e-5, 2e-4}, {-1e-5, -4e-5, -2e-4}, true, 2e-3}};
  c.fastest_f_hz = 10.0;
  c.smallest_tolerance_rad = 1e-5;
  return c;
}

Hello a_hello() {
  Hello h;
  h.protocol = 4;
  h.frame_version = 1;
  h.daemon = "0.9.0";
  h.stream = "tcp://127.0.0.1:5556";
  h.clock = "virtual";
  h.backends = {"none"};
  h.limits = {0.0, 80.0, 20000.0, 1000.0, 0.1, 500.0, 86400.0, 10.0};
  h.drive_rate_hz = 10000.0;
  h.sensor_rate_hz = 1000.0;
  h.output_latency_s = 1e-4;
  h.lease_s = 0.5;
  h.recorder_s = 120.0;
  h.axes.push_back({"rotor", 0.05, 0.0, 80.0, 20000.0, std::nullopt, 0.5, "sim", "modbus-tcp",
                    0.0701, a_calibration(), std::nullopt, std::nullopt, false});
  return h;
}

LoopHealth a_health(bool timing) {
  LoopHealth l{48000, 2, 3, 1, 4, std::nullopt};
  if (timing) l.timing = LoopHealth::Timing{12.5, 40.0, 55.0, 14.0, {3.0, 0.0, 7.0}};
  return l;
}

/// A move's account, under way or ended (on target, with a hold).
MoveAccount a_move(bool ended) {
  MoveAccount m;
  m.state = ended ? firmware::MoveState::on_target : firmware::MoveState::coarse;
  m.target_rad = 0.01;
  m.tolerance_rad = 25e-6;
  m.position_rad = 0.01;
  m.error_rad = 0.0;
  m.on_target = ended;
  if (ended) m.on_target_at_s = 0.4;
  m.steps = 3;
  m.f_hz = 10.0;
  if (ended) {
    m.hold = MoveAccount::Hold{0.5, 1e-6, std::nullopt};
    m.stop_cause = firmware::MoveEnd::on_target;
  }
  return m;
}

RunSummary a_summary() {
  RunSummary s;
  s.cause = firmware::StopCause::link_lost;
  s.output = {firmware::OutputState::confirmed, true, true, 0.0, 3, "ok", true, "ok"};
  s.drive = a_health(true);
  s.sensor = a_health(true);
  s.realtime = {"SCHED_FIFO refused"};
  s.samples = {48000, 4800};
  s.axes.push_back({"rotor", firmware::StopCause::link_lost, s.output, a_move(true), std::nullopt});
  s.calibration.present = true;  // a calibration run that installed none
  s.calibration_error = "the experiment ended link_lost before it was complete";
  return s;
}

RestReport a_rest() {
  RestReport r;
  r.name = "rotor";
  r.position_rad = 0.0125;
  r.noise_m = 0.5e-6;
  r.noise_rad = 5e-5;
  r.age_s = 0.04;
  r.moved_rad = 0.0025;
  r.moved = true;
  r.errors = 2;
  r.stale = true;
  return r;
}

TEST(Messages, HelloRoundTripsWithEachAxisSensorRadius) {
  const Hello h = a_hello();
  const Hello back = over_the_wire(h);
  EXPECT_EQ(json(back), json(h));
  EXPECT_EQ(back.axes.at(0).r2_m, 0.05);
  EXPECT_EQ(json(h).at("axes")[0].at("r2_m"), 0.05) << "the documented place: axes[].r2_m";
  EXPECT_EQ(back.axes.at(0).zero_displacement_m, 0.0701);
  // Protocol 4: nothing of an axis at the top level, for one axis as for several.
  for (const char* mirror : {"sensor", "calibration"}) EXPECT_FALSE(json(h).contains(mirror));
  EXPECT_EQ(json(h).at("backends").size(), 1u) << "the lines' alone";
  Hello none = h;
  none.axes[0].zero_displacement_m.reset();
  EXPECT_TRUE(json(none).at("axes")[0].at("zero_displacement_m").is_null());
  EXPECT_FALSE(over_the_wire(none).axes[0].zero_displacement_m.has_value());
  json without_axes = h;
  without_axes.erase("axes");
  EXPECT_EQ(refusal_key<Hello>(without_axes), "malformed axes");
}

TEST(Messages, LoopHealthRoundTripsWithAndWithoutTiming) {
  for (const bool timing : {false, true}) {
    const LoopHealth l = a_health(timing);
    EXPECT_EQ(json(over_the_wire(l)), json(l));
    EXPECT_EQ(over_the_wire(l).timing.has_value(), timing);
  }
}

TEST(Messages, RequestsRoundTrip) {
  ConfigureRequest c;
  c.drive = {60.0, 20.0, 0.9, 0.7, model::Direction::reverse};
  c.duration_s = 2.5;
  EXPECT_EQ(json(over_the_wire(c)), json(c));
  EXPECT_EQ(over_the_wire(c).drive.direction, model::Direction::reverse);

  StepRequest s;
  s.count = 7;
  s.drive = {40.0, 100.0, 0.95, 0.789, model::Direction::forward};
  s.lease_s = 1.0;
  EXPECT_EQ(json(over_the_wire(s)), json(s));
  s.lease_s.reset();
  EXPECT_FALSE(over_the_wire(s).lease_s.has_value());

  MoveToRequest m;
  m.move.target_rad = -0.002;
  m.move.tolerance_rad = 3e-5;
  m.move.hold_s = 0.5;
  m.move.protect = false;
  m.move.stall_steps = 4;
  m.move.approach = firmware::Approach::forward;
  m.f = 40.0;
  m.lease_s = 2.0;
  EXPECT_EQ(json(over_the_wire(m)), json(m));
  EXPECT_FALSE(over_the_wire(m).V0.has_value());
}

TEST(Messages, TheOtherRequestsAndTheClockRoundTrip) {
  EXPECT_EQ(over_the_wire(StartRequest{2.5}).lease_s, 2.5);
  EXPECT_FALSE(over_the_wire(StartRequest{}).lease_s.has_value());
  const auto c = over_the_wire(CalibrateRequest{40.0, std::nullopt});
  EXPECT_EQ(c.V0, 40.0);
  EXPECT_FALSE(c.lease_s.has_value());
  EXPECT_EQ(over_the_wire(LeaseRequest{123456}).drive_received, 123456u);
  EXPECT_FALSE(over_the_wire(LeaseRequest{}).drive_received.has_value());
  const auto f = over_the_wire(FetchRequest{Stream::sensor, 1000, 4096});
  EXPECT_EQ(f.stream, Stream::sensor);
  EXPECT_EQ(f.first, 1000u);
  EXPECT_EQ(f.count, 4096u);
  EXPECT_EQ(over_the_wire(ClockReply{-42}).board_ns, -42);
  EXPECT_EQ(refusal_key<ClockReply>(json::object()), "malformed board_ns");
}

/// The keys a request encodes with every argument given.
template <class T>
std::set<std::string> encoded_keys(const T& m) {
  const json j = m;
  std::set<std::string> keys;
  for (const auto& [key, value] : j.items()) keys.insert(key);
  return keys;
}

template <std::size_t N>
std::set<std::string> declared(const std::array<firmware::Argument, N>& args) {
  std::set<std::string> names;
  for (const firmware::Argument& a : args) names.emplace(a.name);
  return names;
}

// The names the board's command table admits are the ones the codec writes
// and reads: a request declares them once.
TEST(Messages, EachRequestEncodesExactlyTheArgumentsItDeclares) {
  EXPECT_EQ(encoded_keys(ConfigureRequest{}), declared(arguments_of<ConfigureRequest>()));
  EXPECT_EQ(encoded_keys(StartRequest{1.0}), declared(arguments_of<StartRequest>()));
  EXPECT_EQ(encoded_keys(StepRequest{1, {}, 1.0}), declared(arguments_of<StepRequest>()));
  EXPECT_EQ(encoded_keys(CalibrateRequest{30.0, 1.0}), declared(arguments_of<CalibrateRequest>()));
  EXPECT_EQ(encoded_keys(LeaseRequest{1}), declared(arguments_of<LeaseRequest>()));
  EXPECT_EQ(encoded_keys(FetchRequest{}), declared(arguments_of<FetchRequest>()));
  std::set<std::string> move = declared(MoveToRequest::kWaveformArgs);
  for (const auto& field : firmware::kMoveFields) move.emplace(field.name);
  EXPECT_EQ(encoded_keys(MoveToRequest{{}, 1.0, 1.0, 1.0, 1.0, 1.0}), move);
}

TEST(Messages, RequestsTakeTheDocumentedDefaults) {
  const auto c = decode<ConfigureRequest>({{"V0", 60.0}, {"f", 10.0}, {"duration_s", 1.0}});
  EXPECT_EQ(c.drive.C_dr, 0.95);
  EXPECT_EQ(c.drive.e_dr, 0.789);
  EXPECT_EQ(c.drive.direction, model::Direction::forward);
  const auto m = decode<MoveToRequest>({{"target_rad", 0.01}});
  EXPECT_EQ(m.move.tolerance_rad, 25e-6);
  EXPECT_EQ(m.move.settle_s, 0.1);
  EXPECT_EQ(m.move.timeout_s, 30.0);
  EXPECT_EQ(m.move.stall_steps, 2u);
  EXPECT_TRUE(m.move.protect);
  EXPECT_EQ(m.move.approach, firmware::Approach::either);
}

TEST(Messages, ABadRequestArgumentIsABadArgumentNamingIt) {
  EXPECT_EQ(refusal_key<ConfigureRequest>({{"V0", "high"}, {"f", 10.0}, {"duration_s", 1.0}}),
            "bad_argument V0");
  EXPECT_EQ(refusal_key<ConfigureRequest>({{"V0", 60.0}, {"duration_s", 1.0}}), "bad_argument f");
  EXPECT_EQ(refusal_key<ConfigureRequest>(
                {{"V0", 60.0}, {"f", 10.0}, {"duration_s", 1.0}, {"direction", "sideways"}}),
            "bad_argument direction");
  EXPECT_EQ(refusal_key<StepRequest>({{"V0", 60.0}, {"f", 10.0}, {"count", -1}}),
            "bad_argument count");
  EXPECT_EQ(refusal_key<MoveToRequest>({{"target_rad", 0.0}, {"protect", 1}}),
            "bad_argument protect");
  EXPECT_EQ(refusal_key<StartRequest>({{"lease_s", "long"}}), "bad_argument lease_s");
  EXPECT_EQ(refusal_key<CalibrateRequest>({{"V0", true}}), "bad_argument V0");
  EXPECT_EQ(refusal_key<LeaseRequest>({{"drive_received", -3}}), "bad_argument drive_received");
  EXPECT_EQ(refusal_key<FetchRequest>({{"stream", "video"}, {"first", 0u}, {"count", 1u}}),
            "bad_argument stream");
  EXPECT_EQ(refusal_key<FetchRequest>({{"stream", "drive"}, {"first", 0u}}), "bad_argument count");
}

TEST(Messages, EventsAndSummariesRoundTrip) {
  const RunSummary s = a_summary();
  EXPECT_EQ(json(over_the_wire(s)), json(s));
  RunSummary plain = a_summary();
  plain.axes[0].move.reset();
  plain.calibration = {};
  plain.calibration_error.reset();
  plain.output.acknowledged_V.reset();
  EXPECT_EQ(json(over_the_wire(plain)), json(plain));
  EXPECT_FALSE(json(plain).contains("calibration")) << "only a calibration run has one";

  StateEvent e{BoardState::fault, 123456789, 3, firmware::StopCause::link_lost, s};
  EXPECT_EQ(json(over_the_wire(e)), json(e));
  StateEvent idle{BoardState::idle, 5, std::nullopt, std::nullopt, std::nullopt};
  EXPECT_EQ(json(over_the_wire(idle)), json(idle));
  EXPECT_TRUE(json(idle).at("run").is_null()) << "nil, as documented";

  HealthEvent h{BoardState::running,        99,           a_health(true), a_health(true),
                std::vector{a_move(false)}, std::nullopt, 0.25,           "5eed",
                std::vector{a_rest()}};
  EXPECT_EQ(json(over_the_wire(h)), json(h));
  EXPECT_FALSE(json(h).contains("move")) << "a move of one axis is in `moves` too";
  HealthEvent quiet{
      BoardState::idle, 1, std::nullopt, std::nullopt, std::nullopt, std::nullopt, std::nullopt,
      "5eed",           {}};
  EXPECT_EQ(json(over_the_wire(quiet)), json(quiet));
}

TEST(Messages, AScanAndItsTriggersRoundTrip) {
  ScanAccount a;
  a.axis = "theta";
  a.from_rad = 0.01;
  a.to_rad = -0.03;
  a.velocity_rad_per_s = 0.02;
  a.stage = "done";
  a.zero_displacement_m = 0.0701;
  a.measured_velocity_rad_per_s = 0.0199;
  a.model_velocity_rad_per_s = 0.021;
  a.triggers = ScanAccount::Triggers{0.01, 0.002, 1e-3, 0.0, 21, 21, 1, 0};
  const TriggerPulse p{3, 0.004, 0.00398, 1.25, 1.2501, true};
  a.pulses = std::vector{p, p};
  a.stop_cause = firmware::MoveEnd::on_target;
  EXPECT_EQ(json(over_the_wire(a)), json(a));
  EXPECT_EQ(json(a).at("pulses").size(), 2u);
  ScanAccount running = a;
  running.pulses.reset();
  running.stop_cause.reset();
  EXPECT_FALSE(json(running).contains("pulses")) << "only a summary's account lists them";
  const TriggerEvent e{"5eed", 4, "theta", p};
  EXPECT_EQ(json(over_the_wire(e)), json(e));
  EXPECT_EQ(json(e).at("k"), 3) << "the pulse's fields at the event's top level";
}

TEST(Messages, AMoveAtRestRoundTripsWithTheAxisAsItNowIs) {
  const MovedEvent e{"5eed", 77, "rotor", 25e-6, 0.0025, a_rest()};
  EXPECT_EQ(json(over_the_wire(e)), json(e));
  EXPECT_EQ(json(e).at("rest").at("name"), "rotor");
  RestReport none;
  none.name = "phi";
  EXPECT_TRUE(json(none).at("position_rad").is_null()) << "nil before any reading";
  EXPECT_EQ(json(over_the_wire(none)), json(none));
}

TEST(Messages, StatusRoundTripsIdleAndDuringARun) {
  Status idle;
  idle.state = BoardState::idle;
  idle.board_ns = 42;
  idle.recorder.drive = {0, 0};
  idle.axes.push_back({"rotor", {}, false, std::nullopt, {}});
  EXPECT_EQ(json(over_the_wire(idle)), json(idle));
  EXPECT_TRUE(json(idle).at("axes")[0].at("position").at("position_rad").is_null());
  for (const char* mirror : {"position", "calibration"}) EXPECT_FALSE(json(idle).contains(mirror));
  EXPECT_FALSE(json(idle).contains("run"));

  Status busy = idle;
  busy.state = BoardState::fault;
  busy.controller = true;
  busy.controlled = true;
  busy.fault = firmware::StopCause::link_lost;
  busy.recorder = {{100, 48000}, {10, 4800}};
  busy.axes[0] = {"rotor", {0.0123, 0.07}, true, firmware::StopCause::sensor_fault, a_rest()};
  busy.requests = {{"status", 3}, {"move_to", 1}};
  busy.configured = ConfigureRequest{{80.0, 10.0, 0.95, 0.789, model::Direction::forward}, 4.8};
  RunStatus r;
  r.id = 3;
  r.axes = {"rotor"};
  r.t0_ns = 1'000'000;
  r.duration_s = 4.8;
  r.lease_s = 0.5;
  r.finished = true;
  r.drive = a_health(false);
  r.sensor = a_health(false);
  r.summary = a_summary();
  r.moves = std::vector{a_move(true)};
  r.calibration_progress = 1.0;
  busy.run = r;
  EXPECT_EQ(json(over_the_wire(busy)), json(busy));
  EXPECT_EQ(over_the_wire(busy).run->summary->cause, firmware::StopCause::link_lost);
}

// A state, cause or output state put into any JSON value is its name, as
// the wire and docs/protocol.md say it (never the enum's number).
TEST(Messages, TheWiresEnumsBecomeTheirNamesInJson) {
  EXPECT_EQ(json(BoardState::ramping_down), "ramping_down");
  EXPECT_EQ(json(firmware::StopCause::link_lost), "link_lost");
  EXPECT_EQ(json(firmware::OutputState::enable_unconfirmed), "enable_unconfirmed");
  const json health = HealthEvent{BoardState::running, 1, {}, {}, {}, {}, {}, "a1b2", {}};
  EXPECT_EQ(health.at("state"), "running");
}

TEST(Messages, AReplyOrEventMissingAFieldIsMalformedNamingIt) {
  json hello = a_hello();
  hello.at("axes")[0].erase("r2_m");
  EXPECT_EQ(refusal_key<Hello>(hello), "malformed r2_m");
  json summary = a_summary();
  summary.at("output").erase("zero_confirmed");
  EXPECT_EQ(refusal_key<RunSummary>(summary), "malformed zero_confirmed");
  EXPECT_EQ(refusal_key<StateEvent>({{"state", 3}, {"board_ns", 1}}), "malformed state");
  EXPECT_EQ(refusal_key<StateEvent>({{"state", "asleep"}, {"board_ns", 1}}), "malformed state");
  summary = a_summary();
  summary["cause"] = "gremlins";
  EXPECT_EQ(refusal_key<RunSummary>(summary), "malformed cause");
  summary = a_summary();
  summary.at("output")["state"] = "maybe";
  EXPECT_EQ(refusal_key<RunSummary>(summary), "malformed state");
  EXPECT_EQ(refusal_key<HealthEvent>(json::array()), "malformed ");
}

// An integer field holds an integer, or a float that is a whole number in
// the field's range; anything else is refused by name, never converted
// (a float past an integer type's range has no conversion at all).
TEST(Messages, AnIntegerFieldTakesWholeNumbersInItsRangeOnly) {
  for (const json& bad : {json(1e300), json(-1.0), json(2.5), json(0x1p64), json(-1), json("7")}) {
    json summary = a_summary();
    summary.at("samples")["drive"] = bad;
    EXPECT_EQ(refusal_key<RunSummary>(summary), "malformed drive") << bad;
  }
  json summary = a_summary();
  summary.at("samples")["drive"] = 12.0;
  EXPECT_EQ(decode<RunSummary>(summary).samples.drive, 12u);
  json status = json(Status{});
  status["requests"] = {{"start", 1e300}};
  EXPECT_EQ(refusal_key<Status>(status), "malformed requests.start");
}

// A name that is not text, holding bytes that are not UTF-8 (msgpack does
// not check), is refused by name like any other (the fuzzer's find: showing
// it in the refusal threw).
TEST(Messages, ANameThatIsNotTextIsRefusedWhateverItHolds) {
  const json bad_state = json::array({std::string("\xa6\xa6 not UTF-8")});
  EXPECT_EQ(refusal_key<StateEvent>({{"state", bad_state}, {"board_ns", 1}}), "malformed state");
  EXPECT_EQ(refusal_key<StateEvent>({{"state", std::string("\xa6")}, {"board_ns", 1}}),
            "malformed state");
}

}  // namespace
}  // namespace piezo::protocol

namespace piezo::protocol {
namespace {

// A move's account travels as its fields, its end by name; a start's reply
// carries each run's own part and nothing of the others'.
TEST(Messages, AMovesAccountAndAStartsReplyRoundTrip) {
  for (const bool ended : {false, true}) {
    const MoveAccount m = a_move(ended);
    EXPECT_EQ(json(over_the_wire(m)), json(m));
    EXPECT_EQ(json(m).contains("stop_cause"), ended);
    EXPECT_EQ(json(m).contains("hold_s"), ended);
  }
  EXPECT_EQ(json(a_move(true)).at("stop_cause"), "on_target");
  EXPECT_EQ(json(a_move(true)).at("state"), "on_target");

  StartReply plain{
      7, 1'000, 0.5, 4.8, std::nullopt, std::nullopt, std::nullopt, std::nullopt, std::nullopt};
  EXPECT_EQ(json(over_the_wire(plain)), json(plain));
  EXPECT_EQ(json(plain).size(), 4u) << json(plain).dump();
  StartReply step = plain;
  step.count = 3;
  step.direction = model::Direction::reverse;
  EXPECT_EQ(json(step).at("direction"), "reverse");
  EXPECT_EQ(json(over_the_wire(step)), json(step));
  StartReply move = plain;
  MoveToRequest taken;
  taken.move.target_rad = 0.002;
  taken.V0 = 60.0;
  taken.f = 10.0;
  move.moves = std::vector{StartReply::Move{"rotor", true, 0.07, taken}};
  EXPECT_EQ(json(move).at("moves")[0].at("target_rad"), 0.002);
  EXPECT_EQ(json(move).at("moves")[0].at("approach"), "either");
  EXPECT_EQ(json(over_the_wire(move)), json(move));
  StartReply calibration = plain;
  calibration.calibration = StartReply::Calibration{8, 60.0, {10.0, 20.0}};
  EXPECT_EQ(json(over_the_wire(calibration)), json(calibration));
  EXPECT_FALSE(over_the_wire(calibration).moves.has_value());
}

// A calibration travels as its fields; its declared ranges name the key
// and the board's limit.
TEST(Messages, ACalibrationRoundTripsAndItsRangesAreChecked) {
  const CalibrationRecord c = a_calibration();
  EXPECT_EQ(json(over_the_wire(c)), json(c));
  EXPECT_EQ(json(c).at("frequencies")[0].at("f_hz"), 10.0);
  EXPECT_FALSE(check_calibration_ranges(c, 80.0, 500.0).has_value());
  const auto beyond = check_calibration_ranges(c, 60.0, 500.0);
  ASSERT_TRUE(beyond.has_value());
  EXPECT_EQ(beyond->key, "V0");
  EXPECT_NE(beyond->message.find("(0, 60] V"), std::string::npos) << beyond->message;
  CalibrationRecord wild = c;
  wild.frequencies[0].reverse_rad[1] = 3.0;
  const auto step = check_calibration_ranges(wild, 80.0, 500.0);
  ASSERT_TRUE(step.has_value());
  EXPECT_EQ(step->key, "frequencies[0].reverse_rad[1]");
  json missing = c;
  missing.at("frequencies")[0].erase("f_hz");
  EXPECT_EQ(refusal_key<CalibrationRecord>(missing), "malformed f_hz");
}

// Every key of a reply's or event's field list is a name of its own kind:
// letters, digits and underscores (the docs' tables and every client's
// reading rely on them).
TEST(Messages, TheFieldListsKeysAreWireNames) {
  const auto keys = reply_keys();
  EXPECT_GT(keys.size(), 60u);
  for (const std::string_view key : keys) {
    EXPECT_FALSE(key.empty());
    EXPECT_EQ(
        key.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_"),
        std::string_view::npos)
        << key;
  }
}

}  // namespace
}  // namespace piezo::protocol
