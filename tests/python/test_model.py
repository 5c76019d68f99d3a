"""piezo_rig.model against the CLI: the same parameters give the same
figures to the last digit (the same C++), the same refusals."""

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
    worker = threading.Thread(target=lambda: done.append(model.simulate(duration=30.0, dt=1e-2)))
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
