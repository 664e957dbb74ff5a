"""Figures of models without a [plot] table (issue 8, item 6): hints derived from the model, and no
empty axis in any figure."""

import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

import hybrid_models
from hybrid import HybridSystem, Mode, load_system, periodic_orbit, plot_hints, simulate
from hybrid.cli import main
from hybrid.model.plot_hints import derived_plot_hints
from hybrid.plot.trajectory import orbit_figure, trajectory_figure

MODELS = Path(hybrid_models.__file__).parent
PLOT_KEYS = ("force", "velocity", "displacements", "shade_modes")


def _without_plot(name: str, tmp_path: Path) -> Path:
    """The shipped mode-level file `name`.toml with its [plot] table cut out."""
    text = (MODELS / f"{name}.toml").read_text()
    cut = re.sub(r"(?ms)^\[plot\]\n.*?(?=^\[|\Z)", "", text)
    assert "[plot]" in text
    assert "[plot]" not in cut
    assert "plot" not in tomllib.loads(cut)
    path = tmp_path / f"{name}_noplot.toml"
    path.write_text(cut)
    return path


def _axes_all_have_data(fig) -> None:
    assert fig.axes
    for ax in fig.axes:
        assert ax.has_data(), f"empty axis: {ax.get_title()!r}"
        drawn = [np.asarray(line.get_xydata()) for line in ax.get_lines()]
        assert (
            any(d.size and np.isfinite(d).all() and np.ptp(d[:, 1]) > 0 for d in drawn) or ax.collections
        ), ax.get_title()


@pytest.mark.parametrize("name", ["coulomb", "absorber", "isolator"])
def test_derived_hints_match_the_hand_written_ones(name, tmp_path):
    declared = getattr(hybrid_models, name)().plot
    system = load_system(_without_plot(name, tmp_path))
    assert dict(system.plot) == {}
    hints = plot_hints(system)
    assert hints["displacements"]
    assert hints["force"]
    assert hints["velocity"]
    assert hints["shade_modes"]
    assert {k: hints[k] for k in PLOT_KEYS} == {
        k: list(v) if isinstance(v, tuple | list) else v for k, v in declared.items() if k in PLOT_KEYS
    }


def test_declared_hints_win_and_missing_ones_are_derived():
    system = hybrid_models.absorber()
    assert plot_hints(system)["displacements"] == ["x1", "x2"]  # declared, not the derived x1, x2
    bare = HybridSystem(
        name="half",
        variables=["x", "v"],
        parameters=["k"],
        equations={"x": "v", "v": "-k*x"},
        modes=[Mode("free")],
        transitions=[],
        plot={"displacements": ["v"]},
    )
    hints = plot_hints(bare)
    assert hints["displacements"] == ["v"]
    assert "force" not in hints
    assert hints["units"] == {}
    assert derived_plot_hints(bare) == {"displacements": ["x"], "shade_modes": [], "velocity": "v"}


@pytest.mark.slow
def test_model_file_without_plot_gets_a_full_figure(tmp_path, monkeypatch, capsys):
    # coulomb.toml without [plot], forced: both the CLI's PNG and the figure have data in every axis
    path = _without_plot("coulomb", tmp_path)
    system = load_system(path)
    p = system.preset("forced")
    T = 2 * np.pi / p["Omega"]
    tr = simulate(system, p, (0.0, 6 * T), {n: 0.0 for n in system.variable_names}, samples_per_period=100)
    fig = trajectory_figure(tr)
    assert len(fig.axes) == 4
    _axes_all_have_data(fig)
    orbit = periodic_orbit(system, p, {n: 0.0 for n in system.variable_names}, "stick")
    assert orbit.converged, orbit.message
    fig = orbit_figure(orbit)
    assert len(fig.axes) == 4
    _axes_all_have_data(fig)
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", str(path), "--preset", "forced", "--periods", "5"]) == 0
    assert (tmp_path / "out" / path.stem / "trajectory.png").stat().st_size > 10_000


def test_model_without_a_switching_quantity_has_no_empty_axis():
    # a linear oscillator: nothing switches, so no force panels, and the figure is one row of data
    osc = HybridSystem(
        name="linear",
        variables=["x", "v"],
        parameters=["k", "Omega"],
        equations={"x": "v", "v": "-k*x + sin(Omega*t)"},
        modes=[Mode("free")],
        transitions=[],
        period="2*pi/Omega",
        initial_mode="free",
    )
    hints = plot_hints(osc)
    assert hints["displacements"] == ["x"]
    assert "force" not in hints
    tr = simulate(osc, {"k": 1.0, "Omega": 0.7}, (0.0, 30.0), {"x": 0.0, "v": 0.0}, samples_per_period=50)
    fig = trajectory_figure(tr)
    assert len(fig.axes) == 2
    _axes_all_have_data(fig)
