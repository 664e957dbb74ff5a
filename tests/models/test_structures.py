"""Structures from finite-element matrices in networks, and their Craig-Bampton reduction (issue 32).

References are independent of the builder: :func:`scipy.linalg.eigh` of the full matrices (with
the stuck contact's spring added by hand), the closed-form damping ratio of modal damping, and the
other integrator.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import scipy.io
import scipy.linalg
import scipy.sparse

from hybrid import (
    IDA,
    Exact,
    ModelError,
    SolverOptions,
    load_system,
    periodic_orbit,
    simulate,
    system_from_dict,
)
from hybrid.model.linear import natural_frequencies, reduced_jacobian
from hybrid_models.craig_bampton import craig_bampton
from hybrid_models.structures import Structure, read_matrices

MODELS = Path(__file__).resolve().parents[2] / "models"
BEAM10, BEAM20 = MODELS / "data" / "beam10.npz", MODELS / "data" / "beam20.npz"
KT = 5000.0


def _arrays(path: Path) -> tuple[np.ndarray, np.ndarray, list[str]]:
    z = np.load(path)
    return z["M"], z["K"], [str(d) for d in z["dofs"]]


def _eigh(M: np.ndarray, K: np.ndarray) -> np.ndarray:
    return np.sqrt(scipy.linalg.eigh(K, M, eigvals_only=True))


def _beam_network(structure, tip: str, reduce: int | None = None) -> dict:
    """beam_tip.toml as a dict, the structure given from Python (undamped unless the structure is)."""
    spec = {"matrices": structure} | ({"reduce": {"modes": reduce}} if reduce is not None else {})
    return {
        "model": {"name": "beam_py", "format": "network"},
        "structures": {"beam": spec},
        "nodes": {"slider": {}},
        "springs": {"contact": {"between": [f"beam.{tip}", "slider"], "stiffness": "kt"}},
        "friction": {"tip": {"between": ["slider", "ground"], "sliding": "R"}},
        "forces": {"force": {"on": f"beam.{tip}", "amplitude": "F", "frequency": "Omega"}},
        "parameters": {"kt": {"domain": "positive"}, "R": {"domain": "positive"}, "F": {}, "Omega": {}},
        "presets": {"standard": {"kt": KT, "R": 1.0, "F": 0.5, "Omega": 90.0}},
    }


# ----------------------------------------------------------------------------
# Natural frequencies of the built system against eigh of the full matrices
# ----------------------------------------------------------------------------
def test_full_beam_frequencies_stuck_and_free_equal_eigh():
    # issue 32: the structure's equations (M^-1 written out with 17 digits) keep the spectrum
    M, K, dofs = _arrays(BEAM10)
    system = system_from_dict(_beam_network(Structure.from_arrays(M, K, dofs), "w10"))
    p = system.preset("standard")
    Kstuck = K.copy()
    Kstuck[dofs.index("w10"), dofs.index("w10")] += KT  # the stuck contact: a spring kt to ground
    stuck = natural_frequencies(system, p, "motion|stick")
    free = natural_frequencies(system, p, "motion|slip+")
    np.testing.assert_allclose(stuck[:6], _eigh(M, Kstuck)[:6], rtol=1e-9)
    np.testing.assert_allclose(free[:6], _eigh(M, K)[:6], rtol=1e-9)
    assert stuck[0] > 1.7 * free[0]  # the contact stiffens the first mode (93.2 against 52.5 rad/s)


def test_shipped_full_beam_frequencies_and_modal_damping():
    # beam_tip.toml: modal_damping = [0.005]; free (slipping), every mode has that ratio exactly
    system = load_system(MODELS / "beam_tip.toml")
    p = system.preset("standard")
    M, K, _ = _arrays(BEAM10)
    _, A = reduced_jacobian(system, p, "motion|slip+")
    lam = np.linalg.eigvals(A)
    lam = lam[lam.imag > 0]
    lam = lam[np.argsort(np.abs(lam))]
    np.testing.assert_allclose(np.abs(lam[:6]), _eigh(M, K)[:6], rtol=1e-9)
    np.testing.assert_allclose(-lam.real[:6] / np.abs(lam[:6]), 0.005, rtol=1e-7)


def test_craig_bampton_frequencies_against_full():
    # issue 32 item 2: the reduced model (tip DOF + m fixed-interface modes) of the 20-element beam
    M, K, dofs = _arrays(BEAM20)
    full = Structure.from_arrays(M, K, dofs)
    exact = _eigh(M, K)  # the generalised problem's condition (omega_max/omega_1)^2 ~ 5e7: ~1e-9 apart
    errors = []
    for m in (2, 4, 6, 10):
        red = craig_bampton(full, ["w20"], m)
        table = red.frequencies(3)
        np.testing.assert_allclose(table[:, 0], exact[:3], rtol=1e-8)
        assert np.all(table[:, 1] >= exact[:3] * (1 - 1e-8))  # Rayleigh-Ritz: never below
        errors.append(table[:, 2])
    errors = np.array(errors)
    assert np.all(np.diff(errors, axis=0) <= 0)  # the error falls as modes are added
    # 6 modes (beam_tip_cb.toml): first mode 7.1e-7, second 2.8e-5, third 2.2e-4 relative
    assert errors[2, 0] < 1e-6 and errors[2, 1] < 5e-5 and errors[2, 2] < 5e-4
    # every interior mode kept: the reduction is a change of coordinates, the spectrum unchanged
    red = craig_bampton(full, ["w20"], full.n - 1)
    np.testing.assert_allclose(red.structure.frequencies(), exact, rtol=1e-8)


def test_reduced_beam_stuck_frequencies_against_full_eigh():
    system = load_system(MODELS / "beam_tip_cb.toml")
    p = system.preset("standard")
    M, K, dofs = _arrays(BEAM20)
    Kstuck = K.copy()
    Kstuck[dofs.index("w20"), dofs.index("w20")] += p["kt"]
    w = natural_frequencies(system, p, "motion|stick")
    rel = (w[:3] - _eigh(M, Kstuck)[:3]) / _eigh(M, Kstuck)[:3]
    print("CB (tip + 6 modes), stuck: relative errors of the first 3 frequencies", rel)
    # measured 2.1e-6, 3.2e-5, 2.3e-4: the reduction's error, plus (stuck, the file's modal damping is
    # not proportional) the difference between |lambda| and the undamped frequency
    assert np.all(rel > -1e-8) and rel[0] < 5e-6 and rel[1] < 5e-5 and rel[2] < 5e-4
    # its boundary DOF keeps its name; the modal coordinates are beam_eta1 ... beam_eta6
    names = [v.name for v in system.variables]
    assert "beam_w20" in names and "beam_eta6" in names and "beam_w19" not in names


# ----------------------------------------------------------------------------
# Files
# ----------------------------------------------------------------------------
def test_mtx_and_mat_read_equal_to_npz(tmp_path):
    ref = read_matrices(BEAM10)
    M, K, dofs = _arrays(BEAM10)
    d = tmp_path / "mtx"
    d.mkdir()
    scipy.io.mmwrite(str(d / "M.mtx"), scipy.sparse.coo_matrix(M))
    scipy.io.mmwrite(str(d / "K.mtx"), K)  # dense MatrixMarket
    (d / "dofs.txt").write_text("\n".join(dofs) + "\n")
    scipy.io.savemat(tmp_path / "beam.mat", {"M": scipy.sparse.csc_matrix(M), "K": K, "dofs": dofs})
    scipy.io.savemat(tmp_path / "cell.mat", {"M": M, "K": K, "dofs": np.array(dofs, dtype=object)})
    for path in (d, tmp_path / "beam.mat", tmp_path / "cell.mat"):
        s = read_matrices(path)
        assert s.dofs == ref.dofs
        np.testing.assert_array_equal(s.M, ref.M)
        np.testing.assert_array_equal(s.K, ref.K)


def _bad(tmp_path: Path, **arrays) -> str:
    path = tmp_path / "bad.npz"
    np.savez(path, **arrays)
    with pytest.raises(ModelError) as exc:
        read_matrices(path, where="[structures.beam]")
    return str(exc.value)


def test_bad_matrices_are_refused_with_what_and_where(tmp_path):
    M, K, dofs = _arrays(BEAM10)
    names = np.array(dofs)
    asym = K.copy()
    asym[0, 1] += 1.0
    assert "K is not symmetric" in _bad(tmp_path, M=M, K=asym, dofs=names)
    singular = M.copy()
    singular[0, :] = singular[:, 0] = 0.0
    assert "M is not positive definite" in _bad(tmp_path, M=singular, K=K, dofs=names)
    assert "K is not positive semi-definite" in _bad(tmp_path, M=M, K=-K, dofs=names)
    assert "M is 20x20 but K is 19x19" in _bad(tmp_path, M=M, K=K[1:, 1:], dofs=names)
    assert "given twice" in _bad(tmp_path, M=M, K=K, dofs=np.array(["w1"] * 20))
    assert "20 DOF names for 19 DOFs" in _bad(tmp_path, M=M[1:, 1:], K=K[1:, 1:], dofs=names)
    assert "not valid" in _bad(tmp_path, M=M, K=K, dofs=np.array(dofs[:-1] + ["1x"]))
    assert "no array `K`" in _bad(tmp_path, M=M, dofs=names)
    assert "no DOF names" in _bad(tmp_path, M=M, K=K)
    nan = K.copy()
    nan[3, 3] = np.nan
    assert "not finite" in _bad(tmp_path, M=M, K=nan, dofs=names)
    with pytest.raises(ModelError, match="does not exist"):
        read_matrices(tmp_path / "missing.npz")
    (tmp_path / "junk.npz").write_bytes(b"not a zip file")
    with pytest.raises(ModelError, match="cannot be read as a .npz"):
        read_matrices(tmp_path / "junk.npz")
    (tmp_path / "junk.mat").write_bytes(b"not a mat file at all, long enough to have a header" * 4)
    with pytest.raises(ModelError, match="MATLAB"):
        read_matrices(tmp_path / "junk.mat")
    (tmp_path / "m.csv").write_text("1,2")
    with pytest.raises(ModelError, match="unknown kind of matrix file"):
        read_matrices(tmp_path / "m.csv")
    pickled = tmp_path / "obj.npz"
    np.savez(pickled, M=M, K=K, dofs=np.array(dofs, dtype=object))  # needs a pickle: never loaded
    with pytest.raises(ModelError, match="plain arrays"):
        read_matrices(pickled)


def test_bad_structure_tables_are_refused(tmp_path):
    M, K, dofs = _arrays(BEAM10)
    s = Structure.from_arrays(M, K, dofs)
    net = _beam_network(s, "w10")
    cases = [
        ({"matrices": s, "rayleigh": [1.0]}, "two numbers"),
        ({"matrices": s, "modal_damping": [-0.1]}, ">= 0"),
        ({"matrices": s, "rayleigh": [0.0, 1e-5], "modal_damping": [0.01]}, "one damping"),
        ({"matrices": s, "reduce": {"modes": 50}}, "from 0 to 19"),
        ({"matrices": s, "reduce": {"nodes": 5}}, "modes = N"),
        ({"matrices": 3}, "must be a file name"),
        ({"matrices": str(tmp_path / "nope.npz")}, "does not exist"),
        ({"matrices": s, "colour": "red"}, "unknown key"),
    ]
    for spec, message in cases:
        data = dict(net, structures={"beam": spec})
        with pytest.raises(ModelError, match=message):
            system_from_dict(data)
    data = dict(net, springs={"contact": {"between": ["beam.w11", "slider"], "stiffness": "kt"}})
    with pytest.raises(ModelError, match=r"unknown end `beam.w11`.*DOFs of structures: beam.w1"):
        system_from_dict(data)
    data = dict(net, masses={"beam_w3": {"mass": 1.0}})
    with pytest.raises(ModelError, match="already"):
        system_from_dict(data)


# ----------------------------------------------------------------------------
# Orbits, the frequency response, outputs
# ----------------------------------------------------------------------------
@pytest.mark.slow
def test_reduced_beam_exact_orbit_and_energy_balance():
    system = load_system(MODELS / "beam_tip_cb.toml")
    p = dict(system.preset("standard"), Omega=90.0)
    start = time.perf_counter()
    orbit = periodic_orbit(system, p, options=SolverOptions(method=Exact()))
    print(f"beam_tip_cb exact orbit at Omega = 90 rad/s: {time.perf_counter() - start:.3f} s")
    assert orbit.converged
    fr = orbit.mode_fractions
    assert fr["motion|stick"] > 0.1 and fr["motion|slip+"] > 0.1  # stick-slip
    # one period from the orbit's state on IDA returns there
    T = orbit.period
    tr = simulate(
        system,
        p,
        (orbit.t0, orbit.t0 + T),
        orbit.x0,
        orbit.mode0,
        options=SolverOptions(method=IDA(rtol=1e-10, atol=1e-13)),
    )
    end, x0 = tr.final_values, dict(zip([v.name for v in system.variables], orbit.x0, strict=True))
    for name in ("beam_w20", "v_beam_w20", "beam_eta1"):
        assert abs(end[name] - x0[name]) < 1e-6 * orbit.amplitude[name]
    # over a period the work of the force equals what friction and damping dissipate
    print("energy over a period:", orbit.energy)


@pytest.mark.slow
def test_full_beam_one_period_exact_equals_ida():
    # issue 32: the full 10-element beam (48 states, dense exact path) on both integrators, from rest
    system = load_system(MODELS / "beam_tip.toml")
    p = dict(system.preset("standard"), Omega=90.0, F=3.0)
    x0 = {v.name: 0.0 for v in system.variables}
    span = (0.0, 2 * np.pi / p["Omega"])
    start = time.perf_counter()
    ex = simulate(system, p, span, x0, options=SolverOptions(method=Exact()))
    print(f"beam_tip (full) one period on Exact: {time.perf_counter() - start:.2f} s")
    ida = simulate(system, p, span, x0, options=SolverOptions(method=IDA(rtol=1e-9, atol=1e-12)))
    assert ex.n_transitions >= 1 and ex.n_transitions == ida.n_transitions  # it slips within the period
    a, b = ex.final_values, ida.final_values
    for name in ("beam_w10", "v_beam_w10", "beam_w5", "slider", "W", "D"):
        scale = max(abs(a[name]), 1e-3 * max(abs(a["beam_w10"]), 1e-12))
        assert abs(a[name] - b[name]) < 1e-5 * scale, (name, a[name], b[name])


def test_dof_names_in_json_and_csv(tmp_path):
    out = tmp_path / "out"
    run = subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys; from hybrid.cli import main; sys.exit(main())",
            "simulate",
            str(MODELS / "beam_tip_cb.toml"),
            "--periods",
            "1",
            "--integrator",
            "exact",
            "--out",
            str(out),
            "--json",
            "--no-plot",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr
    summary = json.loads(run.stdout)
    assert "beam_w20" in summary["final_state"] and "beam_eta1" in summary["final_state"]
    header = (out / "trajectory.csv").read_text().splitlines()[0]
    assert "beam_w20 [m]" in header and "v_beam_w20 [m/s]" in header and "beam_eta1 [m kg^(1/2)]" in header
