"""piezo_rig.model against the CLI: the same parameters give the same
figures to the last digit (the same C++), the same refusals."""

import json
import os
import subprocess
import threading
import time

import numpy as np
import pytest

from piezo_rig import model


@pytest.mark.parametrize("friction,direction", [("lugre", "forward"), ("lugre", "reverse"),
                                                ("coulomb", "forward")])
def test_simulate_matches_the_cli_to_the_last_digit(piezo, friction, direction):
    cli = piezo("simulate", "--json", "--model", friction, "--direction", direction,
                "--duration", "0.5", "--set", "V0=60", "--set", "mu=0.12")
    sim = model.simulate(model.Parameters(V0=60, mu=0.12), 0.5, model=friction,
                         direction=direction)
    assert sim.theta_end_rad == cli["theta_end_rad"]
    assert sim.mean_velocity_rad_s == cli["mean_velocity_rad_s"]
    assert sim.integrator["steps"] == cli["integrator"]["steps"]
    assert sim.integrator["method"] == cli["integrator"]["method"]
    assert len(sim.t) == 5001 and sim.t[-1] == pytest.approx(0.5)
    assert sim.theta[-1] == sim.theta_end_rad
    assert (sim.theta_end_rad > 0) == (direction == "forward")


@pytest.mark.parametrize("friction", ["lugre", "coulomb"])
def test_columns_asked_for_are_those_of_the_whole_run(friction):
    whole = model.simulate(duration=0.3, model=friction)
    some = model.simulate(duration=0.3, model=friction, columns=("V", "F_f"))
    assert np.array_equal(some.t, whole.t) and np.array_equal(some.theta, whole.theta)
    assert np.array_equal(some.V, whole.V) and np.array_equal(some.F_f, whole.F_f)
    for name in ("x", "x_dot", "theta_dot", "z"):
        assert len(getattr(some, name)) == 0, name
    assert some.theta_end_rad == whole.theta_end_rad
    assert list(some.to_dataframe().columns) == ["V", "theta", "F_f"]
    # One name as a string; a run after many dropped ones gives the same samples.
    for _ in range(3):
        again = model.simulate(duration=0.3, model=friction, columns="theta_dot")
    assert np.array_equal(again.theta_dot, whole.theta_dot)
    assert model.COLUMNS == ("t", "V", "x", "x_dot", "theta", "theta_dot", "z", "F_f")


def test_an_unknown_column_is_refused_naming_the_allowed_ones():
    with pytest.raises(ValueError) as e:
        model.simulate(duration=0.1, columns=("theta", "omega"))
    assert "columns" in str(e.value) and "'omega'" in str(e.value) and "theta_dot" in str(e.value)


def test_defaults_are_table_1_as_the_cli_has_them(piezo):
    cli = piezo("simulate", "--json", "--duration", "0.01")["parameters"]
    p = model.Parameters().to_dict()
    for name, value in cli.items():
        if name in p:
            assert p[name] == value, name
    assert p["V0"] == 80.0 and p["sigma0"] == 1650 and p["direction"] == "forward"


def test_a_parameter_out_of_range_is_refused_as_the_cli_refuses_it(piezo):
    cli = subprocess.run([piezo.binary, "simulate", "--set", "V0=-5"], capture_output=True,
                         text=True)
    assert cli.returncode == 2
    with pytest.raises(ValueError) as python:
        model.Parameters(V0=-5)
    # "--set: V0: <message>" on the command line, "Parameters: V0: <message>" here.
    message = str(python.value).split(": ", 1)[1]
    assert message in cli.stderr, (message, cli.stderr)
    with pytest.raises(model.ParameterError, match="unknown parameter"):
        model.Parameters(V00=1)
    with pytest.raises(ValueError, match="C_dr\\*e_dr"):
        model.simulate(model.Parameters(e_dr=2.0), 0.1)
    with pytest.raises(ValueError, match="hybrid solves the LuGre model only"):
        model.simulate(duration=0.1, model="coulomb", integrator="hybrid")
    with pytest.raises(ValueError, match="duration"):
        model.simulate(duration=4000)


def test_sensitivity_matches_the_cli(piezo):
    cli = piezo("sensitivity", "--json")
    ours = model.sensitivity()
    assert ours == cli


def test_sobol_and_morris_match_the_cli(piezo):
    cli = piezo("sensitivity", "--method", "sobol", "--params", "V0,mu", "--samples", "8",
                "--runtime", "0.3", "--bootstrap", "20", "--json")
    assert model.sobol(names=["V0", "mu"], samples=8, runtime=0.3, bootstrap=20) == cli
    cli = piezo("sensitivity", "--method", "morris", "--params", "V0,f", "--samples", "3",
                "--runtime", "0.3", "--json")
    assert model.morris(names=["V0", "f"], trajectories=3, runtime=0.3) == cli


def test_sweep_matches_the_cli(piezo):
    cli = piezo("sweep", "--param", "f", "--from", "5", "--to", "40", "--points", "4",
                "--periods", "6", "--model", "lugre", "--json")
    ours = model.sweep("f", cli["values"], periods=6)
    assert list(ours["mean_velocity_rad_s"]) == cli["lugre"]["mean_velocity_rad_s"]
    assert ours["step_rad"].shape == (4,)


def test_identify_recovers_a_friction_level_and_matches_the_cli(piezo, tmp_path):
    truth = model.Parameters(F_N=5.5e-3)
    sim = model.simulate(truth, 0.3)
    t, V, theta = sim.t, sim.V, sim.theta
    csv = tmp_path / "run.csv"
    np.savetxt(csv, np.column_stack([t, V, theta]), delimiter=",", header="t,V,theta",
               comments="", fmt="%.17g")
    fit = model.identify((t, V, t, theta), free=["F_N"])
    assert fit.parameters["F_N"] == pytest.approx(5.5e-3, rel=2e-3)
    low, high = fit.confidence_95["F_N"]
    assert low < fit.parameters["F_N"] < high
    assert fit.fitted.F_N == fit.parameters["F_N"]
    assert fit.theta_fit.shape == t.shape
    cli = piezo("identify", "--log", str(csv), "--params", "F_N", "--json")
    from_file = model.identify(str(csv), free=["F_N"])
    assert from_file.parameters["F_N"] == cli["parameters"]["F_N"]
    assert from_file.rmse_rad == cli["rmse_rad"]


def test_long_work_shows_its_progress_on_pythons_stderr(capsys):
    # sys.stderr, not the process's: a notebook shows it under the cell.
    model.sweep("f", [100, 200, 400], periods=4)
    assert capsys.readouterr().err.endswith("\rsweep: 3/3 points done\n")
    model.morris(names=["V0", "f"], trajectories=2, runtime=0.05)
    assert "sensitivity (morris): 6/6 runs done\n" in capsys.readouterr().err
    model.show_progress(False)
    try:
        model.sweep("f", [100, 200], periods=4)
        assert capsys.readouterr().err == ""
    finally:
        model.show_progress(True)


def test_the_interpreter_goes_on_while_the_model_runs():
    done = []
    # 300 s of motor: a quarter of a second or more of work.
    worker = threading.Thread(target=lambda: done.append(model.simulate(duration=300.0, dt=1e-1)))
    worker.start()
    ticks = 0
    while worker.is_alive():
        time.sleep(0.005)
        ticks += 1
    worker.join()
    # With the lock held for the whole simulation this thread could not wake.
    assert done and ticks >= 5, ticks


def test_simulation_as_a_dataframe():
    frame = model.simulate(duration=0.01).to_dataframe()
    assert list(frame.columns) == ["V", "x", "x_dot", "theta", "theta_dot", "z", "F_f"]
    assert frame.index.name == "t" and len(frame) == 101


def test_parameters_pickle_whole():
    import pickle
    p = model.Parameters(V0=50, mu=0.12, direction="reverse")
    q = pickle.loads(pickle.dumps(p))
    assert q.to_dict() == p.to_dict()


def interrupt_in(seconds):
    """Ctrl-C to this process after `seconds` (as a notebook's interrupt)."""
    import signal
    timer = threading.Timer(seconds, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    return timer


def test_ctrl_c_stops_a_long_study():
    # About 35,000 simulations, minutes on two cores: the interrupt stops it
    # once the jobs under way have finished.
    started = time.monotonic()
    interrupt_in(0.5)
    with pytest.raises(KeyboardInterrupt):
        model.sobol(samples=2048, runtime=4.8, bootstrap=0)
    assert time.monotonic() - started < 45


def test_ctrl_c_stops_a_long_simulation():
    # An hour of motor time at a tight tolerance: tens of seconds.
    started = time.monotonic()
    interrupt_in(0.5)
    with pytest.raises(KeyboardInterrupt):
        model.simulate(duration=3600, dt=1e-2, tolerance=1e-8)
    assert time.monotonic() - started < 10


# -- what a stranger met (each failed before its fix) ---------------------

def test_observe_checks_its_arrays_and_names_them():
    t = np.linspace(0, 0.1, 1001)
    V = np.zeros_like(t)
    with pytest.raises(ValueError, match="observe: theta: 1 values against 2000000 of t"):
        model.observe(t, V, np.linspace(0, 1, 2_000_000), [0.0])
    with pytest.raises(ValueError, match="observe: drive_V: 3 values against 1001 of drive_t"):
        model.observe(t, [0.0, 1.0, 2.0], t, np.zeros_like(t))
    with pytest.raises(ValueError, match="observe: t: 2 dimensions"):
        model.observe(t, V, np.zeros((2, 3)), np.zeros(6))
    with pytest.raises(ValueError, match="observe: drive_t: sample 5 is nan"):
        model.observe(np.where(np.arange(1001) == 5, np.nan, t), V, t, np.zeros_like(t))
    with pytest.raises(ValueError, match="observe: t: sample 2 .* is before the one before"):
        model.observe(t, V, [0.0, 0.2, 0.1], [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="observe: theta: sample 0 is inf"):
        model.observe(t, V, [0.0], [np.inf])
    with pytest.raises(TypeError, match="observe: theta: expected an array of numbers"):
        model.observe(t, V, [0.0], ["a"])
    # NaN angles are failed readings, skipped.
    seen = model.observe(t, V, [0.0, 0.05], [0.0, np.nan])
    assert len(seen.t) == 1
    with pytest.raises(ValueError, match="identify: theta: 2 values against 3 of t"):
        model.identify((t, V, [0.0, 0.1, 0.2], [0.0, 0.0]))
    with pytest.raises(ValueError, match="identify: theta: 1 good readings for 1 free"):
        model.identify(([0.0, 1.0], [0.0, 0.0], [0.5], [0.0]), free="F_N")


def test_studies_are_about_the_parameters_they_are_given():
    default, at_60 = model.sensitivity(), model.sensitivity(model.Parameters(V0=60))
    assert default["parameters"][0]["levels"] == [72.0, 76.0, 80.0, 84.0, 88.0]  # the paper's
    assert at_60["parameters"][0]["levels"] == [54.0, 57.0, 60.0, 63.0, 66.0]
    assert at_60["parameters"][1]["levels"] == [8.0, 9.0, 10.0, 11.0, 12.0]
    assert at_60["parameters"][0]["mean_velocity_rad_s"] != default["parameters"][0][
        "mean_velocity_rad_s"]
    with pytest.raises(ValueError, match="morris: trajectories: 0: allowed: >= 2"):
        model.morris(trajectories=0)
    with pytest.raises(ValueError, match="sobol: samples: 4: allowed: >= 8"):
        model.sobol(samples=4)
    with pytest.raises(ValueError, match="sobol: range_pct: 150: allowed: \\(0, 100\\) %"):
        model.sobol(range_pct=150)
    with pytest.raises(ValueError, match="morris: names: V: .*allowed"):
        model.morris(names=["V"])
    one = model.sobol(names="V0", samples=8, runtime=0.2, bootstrap=10)  # one name, not letters
    assert [p["name"] for p in one["parameters"]] == ["V0"]


def test_errors_name_the_python_argument_at_the_call_that_got_it():
    with pytest.raises(TypeError, match="Parameters: V0: expected a number .*got str '60'"):
        model.Parameters(V0="60")
    with pytest.raises(TypeError, match="simulate: duration: expected a number .*got str '1'"):
        model.simulate(model.Parameters(), "1")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="Parameters: C_dr\\*e_dr: .* 1.9 .*allowed range"):
        model.Parameters(e_dr=2)
    p = model.Parameters()
    with pytest.raises(ValueError, match="C_dr\\*e_dr"):
        p.e_dr = 2
    assert p.e_dr == model.Parameters().e_dr  # left as it was
    assert p.replace(C_dr=0.5, e_dr=1.5).D == pytest.approx(0.75)  # together, they fit
    with pytest.raises(TypeError, match="Parameters: sigma0: expected a number"):
        p.sigma0 = "x"  # type: ignore[assignment]
    with pytest.raises(ValueError, match="simulate: model: 'lugre2' \\(allowed: lugre, coulomb\\)"):
        model.simulate(duration=0.1, model="lugre2")
    with pytest.raises(TypeError, match="sweep: periods: expected an integer"):
        model.sweep("f", [5.0], periods=2.5)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="sweep: name: Vx: unknown"):
        model.sweep("Vx", [5.0])


def test_parameters_round_trip():
    p = model.Parameters(V0=60, direction="reverse")
    assert model.Parameters() == model.Parameters() and p != model.Parameters()
    assert model.Parameters.from_json(p.to_json()) == p
    assert model.Parameters.from_json(p.to_json()).direction == "reverse"
    import pickle
    assert pickle.loads(pickle.dumps(p)) == p
    with pytest.raises(TypeError):
        hash(p)  # mutable: equal by value, so not hashable
    with pytest.raises(ValueError, match="Parameters.from_json: direction"):
        model.Parameters.from_json('{"direction": "sideways"}')


def test_a_fit_frees_only_what_its_model_uses(tmp_path, piezo, source):
    log_dir = tmp_path / "run"
    piezo("run", "--config", os.path.join(source, "configs", "sim.toml"), "--set",
          "run.clock=virtual", "--duration", "0.5", "--out", str(log_dir), "--json")
    coulomb = model.identify(log_dir, model="coulomb", max_iterations=5)
    assert sorted(coulomb.parameters) == ["F_N", "d_e"]
    with pytest.raises(ValueError, match="identify: free: sigma0: the coulomb model does not "
                                         "use it"):
        model.identify(log_dir, model="coulomb", free=["sigma0", "F_N"])
    with pytest.raises(ValueError, match="identify: free: no parameter named"):
        model.identify(log_dir, free=[])
    cli = subprocess.run([piezo.binary, "identify", "--log", str(log_dir / "run.h5"), "--model",
                          "coulomb", "--json"], capture_output=True, text=True)
    assert sorted(json.loads(cli.stdout)["parameters"]) == ["F_N", "d_e"], cli.stderr


def test_a_logs_arrays_give_the_logs_fit(tmp_path, piezo, source):
    from piezo_rig import log

    log_dir = tmp_path / "run"
    piezo("run", "--config", os.path.join(source, "configs", "sim.toml"), "--set",
          "run.clock=virtual", "--duration", "0.5", "--out", str(log_dir), "--json")
    run = log.open_run(log_dir)
    whole = model.identify(run, free=["F_N"], max_iterations=5)
    arrays = model.identify(run.fit_arrays(), run.parameters, free=["F_N"],
                            max_iterations=5)
    assert arrays.rmse_rad == whole.rmse_rad and arrays.parameters == whole.parameters


def test_a_csv_with_empty_cells_is_read(tmp_path):
    sim = model.simulate(duration=0.05)
    rows = ["t,V,theta"] + [f"{t!r},{V!r},{'' if i % 10 == 3 else repr(th)}"
                            for i, (t, V, th) in enumerate(zip(sim.t, sim.V, sim.theta))]
    path = tmp_path / "gaps.csv"
    path.write_text("\n".join(rows) + "\n")
    data, _ = model.load_fit_data(path)
    assert len(data.t) == len(sim.t) - len(range(3, len(sim.t), 10))


# -- hangs and silent results a stranger found (each failed before its fix) --

def _child(code):
    """A child interpreter running `code`, its stderr read line by line."""
    import sys
    # Ctrl-C as at a terminal, whatever this process was started with.
    code = "import signal\nsignal.signal(signal.SIGINT, signal.default_int_handler)\n" + code
    return subprocess.Popen([sys.executable, "-c", code], stderr=subprocess.PIPE, text=True,
                            env=dict(os.environ, PYTHONUNBUFFERED="1"))


def _interrupted_after(child, wanted, limit=120):
    """Waits for a stderr line containing `wanted`, sends SIGINT, and returns
    (seconds from the signal to the child's exit, everything it wrote)."""
    import signal
    seen, started = [], time.monotonic()
    for line in child.stderr:
        seen.append(line)
        if wanted in line or time.monotonic() - started > limit:
            break
    signalled = time.monotonic()
    child.send_signal(signal.SIGINT)
    _, rest = child.communicate(timeout=60)
    return time.monotonic() - signalled, "".join(seen) + (rest or "")


def test_a_stiff_simulation_warns_shows_progress_and_answers_ctrl_c():
    # J inside its range, the rotor's equation stiff: 0.1 s of motor took
    # about 40 s, and the integration checked for Ctrl-C (and showed
    # progress) only per drive piece. Now within a piece too; a slow one
    # names its parameters. A second of motor, so that the warning's
    # projection (ten minutes or so here) is over its minute on any machine.
    child = _child("from piezo_rig import model\n"
                   "model.simulate(model.Parameters(J=1e-12), 1.0)")
    waited, stderr = _interrupted_after(child, "slow:")
    assert "simulate: t " in stderr, stderr
    assert "stiff with J=1e-12 kg m^2" in stderr, stderr
    assert "KeyboardInterrupt" in stderr, stderr
    # Measured at 0.1-0.2 s (the interpreter's own exit included); the
    # bound is for a loaded machine, far below the minute it took before.
    assert waited < 5, stderr


def test_a_fit_on_angles_in_degrees_answers_ctrl_c(tmp_path, piezo, source):
    log_dir = tmp_path / "run"
    piezo("run", "--config", os.path.join(source, "configs", "sim.toml"), "--set",
          "run.clock=virtual", "--duration", "0.5", "--out", str(log_dir), "--json")
    child = _child("import numpy as np\n"
                   "from piezo_rig import log, model\n"
                   f"drive_t, drive_V, t, theta = log.open_run({str(log_dir)!r}).fit_arrays()\n"
                   "model.identify((drive_t, drive_V, t, np.degrees(theta)))")
    waited, stderr = _interrupted_after(child, "iteration 1")
    # Stopped by the interrupt (it ran on for minutes, deaf to it), or done
    # before it came on a fast machine: either way within seconds.
    assert "KeyboardInterrupt" in stderr or child.returncode == 0, stderr
    assert waited < 5, stderr


def _two_time_bases(path):
    import h5py
    with h5py.File(path, "w") as f:
        t = np.linspace(0.0, 1.0, 10_001)
        f["t"], f["V"] = t, 80.0 * (t * 10 % 1)
        f["theta_t"] = np.linspace(0.0, 1.0, 1_001)
        f["theta"] = np.linspace(0.0, 1e-3, 1_001)


def test_an_angle_on_its_own_time_base_is_refused_without_its_times(tmp_path):
    from piezo_rig import log
    path = tmp_path / "two-bases.h5"
    _two_time_bases(path)
    with pytest.raises(ValueError, match=r"theta: 1001 values against 10001 times in t .*"
                                         r"its own times: --theta-t DATASET, theta_t="):
        model.load_fit_data(path, t="t", V="V", theta="theta")
    with pytest.raises(ValueError, match="theta: 1001 values against 10001 times in t"):
        model.identify(path, layout={"t": "t", "V": "V", "theta": "theta"})
    with pytest.raises(ValueError, match=r"theta has 1001 values against 10001 times in t "
                                         r"\(an angle sampled at other times needs its own"):
        log.open_run(path, t="t", V="V", theta="theta")
    # Said with its own times, the angle spans the whole second.
    data, _ = model.load_fit_data(path, t="t", V="V", theta="theta", theta_t="theta_t")
    assert len(data.t) == 1_001 and data.t[-1] == pytest.approx(1.0)
    assert log.open_run(path, t="t", V="V", theta="theta", theta_t="theta_t").sensor.t.iloc[-1] == 1.0


def test_a_fit_stopped_by_max_iterations_says_it_did_not_converge(tmp_path, piezo, source):
    log_dir = tmp_path / "run"
    piezo("run", "--config", os.path.join(source, "configs", "sim.toml"), "--set",
          "run.clock=virtual", "--duration", "0.5", "--out", str(log_dir), "--json")
    stopped = model.identify(log_dir, free=["F_N", "d_e"], max_iterations=1,
                             params=model.Parameters(F_N=0.02))
    assert not stopped.converged
    assert stopped.stop_reason == "stopped at max_iterations = 1"
    assert stopped.notes[0].startswith("not converged (stopped at max_iterations = 1)")
    whole = model.identify(log_dir, free=["F_N"], max_iterations=200)
    assert whole.converged and whole.stop_reason.startswith("converged"), whole.stop_reason
    start = tmp_path / "start.toml"
    start.write_text("[model]\nF_N = 0.02\n")
    args = ["identify", "--log", str(log_dir / "run.h5"), "--params", "F_N,d_e", "--config",
            str(start), "--max-iterations", "1"]
    cli = piezo(*args, "--json")
    assert cli["converged"] is False and cli["stop_reason"] == "stopped at max_iterations = 1"
    text = piezo(*args)
    assert "after 1 iterations, stopped at max_iterations = 1" in text
    assert "note: not converged" in text


def test_a_fit_and_its_data_come_back_from_a_worker_process(tmp_path, piezo, source):
    import pickle
    from concurrent.futures import ProcessPoolExecutor
    sim = model.simulate(duration=0.2)
    data = model.fit_data(sim.t, sim.V, sim.t[::10], sim.theta[::10])
    again = pickle.loads(pickle.dumps(data))
    assert np.array_equal(again.theta, data.theta) and again.ramp_time == data.ramp_time
    # FitData is what identify fits, as its docstring says.
    fit = model.identify(data, free=["F_N"], max_iterations=3)
    with ProcessPoolExecutor(1) as pool:
        back = pool.submit(model.identify, data, free=["F_N"], max_iterations=3).result()
    assert back == fit and back.parameters == fit.parameters
    assert np.array_equal(back.data.t, data.t)


def test_results_compare_by_value():
    a, b = model.simulate(duration=0.05), model.simulate(duration=0.05)
    assert a == b and not (a != b)
    c = model.simulate(model.Parameters(V0=60), 0.05)
    assert a != c
    with pytest.raises(TypeError):
        hash(a)


def test_a_study_without_resamples_gives_no_interval_and_no_names_is_refused():
    s = model.sobol(names=["V0", "f"], samples=8, runtime=0.2, bootstrap=0)
    assert all(p["S1_interval"] is None and p["ST_interval"] is None for p in s["parameters"])
    with pytest.raises(ValueError, match="sobol: names: empty"):
        model.sobol(names=[], samples=8, runtime=0.2)
    with pytest.raises(ValueError, match="morris: names: empty"):
        model.morris(names=[], trajectories=2, runtime=0.2)


def test_a_simulation_larger_than_memory_is_refused_naming_dt():
    with pytest.raises(ValueError, match=r"simulate: dt: 1e-09 s: 3\.6e\+12 samples of 8 columns "
                                         r"need .* GiB, more than this machine's"):
        model.simulate(duration=3600, dt=1e-9)
