"""Command line with network files (issue 8): a path to a network file works wherever MODEL is
accepted, ``hybrid show`` prints the network and the derived automaton, bad files fail cleanly."""

import json
from pathlib import Path

import hybrid_models
from hybrid.cli import main

MODEL_DIR = Path(hybrid_models.__file__).parent


def run(argv, capsys):
    code = main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_show_prints_the_network_and_the_components_and_transitions_of_two_friction_elements(capsys):
    code, out, err = run(["show", str(MODEL_DIR / "absorber_two_friction.toml")], capsys)
    assert code == 0, err
    assert out.startswith("network `absorber_two_friction`")
    assert "u --]||[-- x2" in out
    assert "ground --]||[-- x1" in out
    assert (
        "10 variables, 1 own mode(s), 2 components (6 local modes, composed on demand), 8 transitions, "
        "initial mode motion|stick|stick"
    ) in out
    rows = [line.split() for line in out.splitlines()]
    assert ["motion", "x1,", "v1,", "x2,", "v2,", "W,", "D", "-"] in rows
    assert ["H", "stick", "u", "vel_u,", "f_H"] in rows
    assert ["H", "slip+", "-", "f_H,", "u,", "vel_u"] in rows
    assert ["G", "slip-", "-", "f_G"] in rows
    assert ["G.stop-", "slip-", "stick", "rising", "w_G", "v1", "=", "0"] in rows
    assert ["H.breakaway+", "stick", "slip+", "rising", "f_H", "-", "R", "-"] in rows


def test_show_a_built_in_mode_level_model(capsys):
    code, out, err = run(["show", "absorber"], capsys)
    assert code == 0, err
    assert "network" not in out
    rows = {line.split()[0]: line.split()[1:] for line in out.splitlines() if line.strip()}
    assert rows["stick"] == ["x1,", "v1,", "x2,", "v2,", "u,", "W,", "D", "-"]
    assert rows["slip+"] == ["x1,", "v1,", "x2,", "v2,", "W,", "D", "u"]
    assert any(
        line.split() == ["breakaway+", "stick", "slip+", "rising", "H", "-", "R", "-"]
        for line in out.splitlines()
    )


def test_orbit_of_a_network_file_by_path(tmp_path, capsys):
    code, out, err = run(
        ["orbit", str(MODEL_DIR / "coulomb_network.toml"), "--json", "--no-plot", "--out", str(tmp_path)],
        capsys,
    )
    assert code == 0, err
    orbit = json.loads(out)
    assert orbit["model"] == "coulomb_network"
    assert orbit["converged"]
    # pure slip: each reversal one switch through `stick`, held for no time (issue 30: the sequence
    # has the modes the period spends time in)
    held = {m for m, f in orbit["mode_fractions"].items() if f > 0}
    assert set(orbit["mode_sequence"]) == held == {"motion|slip+", "motion|slip-"}
    assert orbit["transitions_per_period"] == 2


def test_a_bad_network_file_fails_in_one_line_naming_the_file_and_element(tmp_path, capsys):
    text = (MODEL_DIR / "sequential.toml").read_text().replace('sliding = "R"', "sliding = -0.5")
    path = tmp_path / "my_damper.toml"
    path.write_text(text)
    for command in (["show"], ["simulate"], ["orbit"]):
        code, out, err = run([*command, str(path)], capsys)
        assert code == 2
        assert (
            err
            == "hybrid: error: my_damper.toml: [friction.H] `sliding` is -0.5: a friction level must be > 0\n"
        )


def test_show_draws_the_network_of_a_network_file_and_refuses_a_mode_level_model(tmp_path, capsys):
    png = tmp_path / "net.png"
    code, out, err = run(["show", str(MODEL_DIR / "isolator_base.toml"), "--out", str(png)], capsys)
    assert code == 0, err
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert png.stat().st_size > 5000
    assert f"wrote {png}" in err
    code, out, err = run(["show", "coulomb", "--out", str(tmp_path / "c.png")], capsys)
    assert code == 2, err
    assert out == ""
    assert err == "hybrid: error: model `coulomb` is not a network file: there is no network to draw\n"
    assert not (tmp_path / "c.png").exists()
