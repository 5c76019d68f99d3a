"""piezo_rig.log on piezo's own logs, another tool's HDF5 file and a file in
MATLAB v7.3's layout; h5py is the reference."""

import json
import os

import h5py
import numpy as np
import pytest

from piezo_rig import log, model


@pytest.fixture(scope="module")
def logged_run(tmp_path_factory, piezo, source):
    out = tmp_path_factory.mktemp("runs") / "first"
    piezo("run", "--config", os.path.join(source, "configs", "sim.toml"), "--set",
          "run.clock=virtual", "--duration", "1", "--out", str(out), "--json")
    return out


def test_a_piezo_log_reads_whole(logged_run):
    run = log.open_run(logged_run)
    with h5py.File(logged_run / "run.h5") as f:
        # Its one axis under /axes/NAME, as a group move's each.
        assert f.attrs["axes"].decode() == "rotor" and run.axes == ["rotor"] and run.axis == "rotor"
        for group, frame in (("drive", run.drive), ("sensor", run.sensor),
                             ("observer", run.observer)):
            for name in f["axes/rotor/" + group]:
                np.testing.assert_array_equal(frame[name].to_numpy(),
                                              f["axes/rotor/" + group][name][()])
        assert run.status == f.attrs["status"].decode() == "completed"
        # Attributes in their types: numbers as numbers, JSON maps parsed.
        assert run.attrs["drive_latency_s"] == float(f.attrs["drive_latency_s"].decode())
        assert run.attrs["model_parameters"] == json.loads(f.attrs["model_parameters"].decode())
        assert run.attrs["version"] == f.attrs["version"].decode()
    assert len(run.drive) > 10000 and len(run.sensor) > 1000
    assert run.summary["stop_cause"] == run.stop_cause == "completed"
    assert run.config["drive"]["backend"] == "sim"
    assert run.model_parameters["V0"] > 0
    drive_t, drive_V, t, theta = run.fit_arrays()
    assert len(t) == np.count_nonzero(~np.isnan(run.sensor["theta"]))


def test_a_log_written_before_axes_reads_as_before(source):
    """Its one axis at the root (tests/data/logs-before-axes)."""
    path = os.path.join(source, "tests", "data", "logs-before-axes", "completed")
    run = log.open_run(path)
    with h5py.File(os.path.join(path, "run.h5")) as f:
        assert "axes" not in f and "axes" not in f.attrs
        np.testing.assert_array_equal(run.drive["V"].to_numpy(), f["drive/V"][()])
    assert run.axes == [] and run.status == "completed" and len(run.sensor) > 100
    drive_t, drive_V, t, theta = run.fit_arrays()
    assert len(drive_t) == len(drive_V) > 1000 and len(t) == len(theta) > 100
    with pytest.raises(KeyError, match="the log holds one axis"):
        log.open_run(path, axis="phi")


def test_identify_takes_a_log_as_the_cli_does(logged_run, piezo):
    cli = piezo("identify", "--log", str(logged_run / "run.h5"), "--params", "F_N", "--json")
    fit = model.identify(log.open_run(logged_run), free=["F_N"])
    assert fit.parameters["F_N"] == cli["parameters"]["F_N"]
    assert fit.samples == cli["samples"]


@pytest.fixture(scope="module")
def group_run(tmp_path_factory, piezo, source):
    out = tmp_path_factory.mktemp("runs") / "group"
    piezo("move", "--config", os.path.join(source, "configs", "three-axes.toml"),
          "--to", "theta=0.004", "--to", "phi=-0.006", "--out", str(out), "--json")
    return out


def test_a_group_moves_log_reads_axis_by_axis(group_run, piezo):
    with pytest.raises(KeyError, match=r"required: the log holds several axes \(theta, phi\)"):
        log.open_run(group_run)
    with pytest.raises(KeyError, match="'chi' is not an axis of the log"):
        log.open_run(group_run, axis="chi")
    theta, phi = (log.open_run(group_run, axis=a) for a in ("theta", "phi"))
    assert theta.axes == phi.axes == ["theta", "phi"] and phi.axis == "phi"
    with h5py.File(group_run / "run.h5") as f:
        for name in f["axes/phi/drive"]:
            np.testing.assert_array_equal(phi.drive[name].to_numpy(), f["axes/phi/drive"][name][()])
    # Each axis its own account, angle and parameters (phi: its own rotor).
    assert theta.summary["move"]["target_rad"] == 0.004
    assert phi.summary["move"]["target_rad"] == -0.006
    assert phi.stop_cause == theta.stop_cause == "on_target" and phi.status == "completed"
    assert abs(phi.sensor["theta"].iloc[-1] + 0.006) < 1e-4
    assert phi.attrs["plant_parameters"]["J"] == 3e-6 != theta.attrs["plant_parameters"]["J"]
    # identify reads the axis as the CLI does.
    cli = piezo("identify", "--log", str(group_run / "run.h5"), "--axis", "phi", "--params",
                "F_N", "--json")
    fit = model.identify(phi, free=["F_N"])
    assert fit.parameters["F_N"] == cli["parameters"]["F_N"] and fit.samples == cli["samples"]


def foreign_file(path, matlab):
    """A run as another tool would save it: our simulation, its own names;
    MATLAB v7.3 keeps vectors as 1 x n matrices after a 512-byte user block."""
    sim = model.simulate(model.Parameters(F_N=5.2e-3), 0.3)
    with h5py.File(path, "w", userblock_size=512 if matlab else 0) as f:
        for name, values in (("t", sim.t), ("u", sim.V), ("phi", sim.theta)):
            data = values.reshape(1, -1) if matlab else values
            d = f.create_dataset(f"data/{name}", data=data)
            if matlab:
                d.attrs["MATLAB_class"] = np.bytes_("double")
    return sim


@pytest.mark.parametrize("matlab", [False, True])
def test_another_tools_file_by_its_dataset_names(tmp_path, piezo, matlab):
    path = tmp_path / ("bench.mat" if matlab else "bench.h5")
    sim = foreign_file(path, matlab)
    run = log.open_run(path, t="/data/t", V="/data/u", theta="/data/phi")
    np.testing.assert_array_equal(run.sensor["theta"], sim.theta)
    np.testing.assert_array_equal(run.drive["V"], sim.V)
    layout = {"t": "/data/t", "V": "/data/u", "theta": "/data/phi"}
    fit = model.identify(str(path), free=["F_N"], layout=layout)
    assert fit.parameters["F_N"] == pytest.approx(5.2e-3, rel=5e-3)
    cli = piezo("identify", "--log", str(path), "--t", "/data/t", "--V", "/data/u", "--theta",
                "/data/phi", "--params", "F_N", "--json")
    assert fit.parameters["F_N"] == cli["parameters"]["F_N"]


def test_a_missing_dataset_is_named(tmp_path):
    path = tmp_path / "bench.h5"
    foreign_file(path, False)
    with pytest.raises(KeyError, match="/data/theta"):
        log.open_run(path, t="/data/t", V="/data/u", theta="/data/theta")
    with pytest.raises(FileNotFoundError):
        log.open_run(tmp_path / "nothing")


def test_the_observer_on_a_log_is_the_logs_observer(logged_run):
    # piezo run's observer ran beside the run; the same code on the logged
    # drive and angle, with the run's ramp (a drive period) and latency,
    # gives the same rows.
    run = log.open_run(logged_run)
    gains = run.config.get("observer", {})
    seen = model.observe(run.drive["t"], run.drive["V"], run.sensor["t"], run.sensor["theta"],
                         model.Parameters.from_json(json.dumps(run.model_parameters)),
                         alpha=gains.get("alpha", 0.3), beta=gains.get("beta", 0.05),
                         gate_rad=gains.get("gate_rad", 1e-3),
                         ramp_time=1 / run.config["drive"]["rate_hz"],
                         latency=run.attrs["drive_latency_s"])
    assert len(seen.t) == len(run.observer) > 1000
    for column in ("t", "theta_hat", "theta_dot_hat", "x_hat", "z_hat", "F_hat", "residual",
                   "theta_open"):  # bit for bit
        np.testing.assert_array_equal(getattr(seen, column), run.observer[column],
                                      err_msg=column)
    assert seen.summary["samples"] == len(seen.t)
    with pytest.raises(ValueError, match="alpha"):
        model.observe([0, 1], [0, 0], [0.5], [0.0], alpha=2)


def test_a_csv_as_identify_reads_it(tmp_path):
    sim = model.simulate(duration=0.05)
    path = tmp_path / "run.csv"
    np.savetxt(path, np.column_stack([sim.t, sim.V, sim.theta]), delimiter=",",
               header="t,V,theta", comments="", fmt="%.17g")
    run = log.open_run(path)
    np.testing.assert_array_equal(run.sensor["theta"], sim.theta)
    np.testing.assert_array_equal(run.drive["V"], sim.V)
    with pytest.raises(KeyError, match="phi"):
        log.open_run(path, theta="phi")
