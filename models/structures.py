"""Linear structures given by matrices: :class:`Structure`, read from files and checked.

A structure is ``M q'' + C q' + K q = f`` over named degrees of freedom (DOFs) ``q``, with
``M`` symmetric positive definite, ``K`` symmetric positive semi-definite and ``C`` symmetric
positive semi-definite. Units are those of the matrices: SI is assumed (``M`` [kg] or [kg m^2],
``K`` [N/m] or [N m/rad], ``C`` [N s/m]); a network's springs, forces and friction levels attached
to a DOF must be in the same units.

Files (:func:`read_matrices`), dense or sparse:

* ``.npz`` (:func:`numpy.savez`): dense arrays ``M``, ``K``, optionally ``C``, and ``dofs`` (the
  names, strings); read without pickles;
* ``.mat`` (MATLAB, :func:`scipy.io.loadmat`): variables ``M``, ``K``, optionally ``C`` (dense or
  sparse) and ``dofs`` (a char matrix or a cell array of strings);
* a directory holding MatrixMarket files ``M.mtx``, ``K.mtx``, optionally ``C.mtx``
  (:func:`scipy.io.mmread`) and ``dofs.txt`` (one name per line).

Damping is the file's ``C``, or Rayleigh's ``C = a M + b K`` (:func:`rayleigh`), or modal damping
ratios (:func:`modal_damping`), one of them at most.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.io
import scipy.linalg
import scipy.sparse

from hybrid import ModelError

__all__ = [
    "MAX_DOFS",
    "Structure",
    "modal_damping",
    "natural_frequencies",
    "rayleigh",
    "read_matrices",
]

#: Most DOFs of a structure read from a file (dense matrices of this size are 200 MB).
MAX_DOFS = 5000
#: Largest matrix file read [bytes].
MAX_MATRIX_BYTES = 500_000_000
#: Relative tolerance of the symmetry and definiteness checks.
SYMMETRY_TOL = 1e-10


def _valid_dof(name: object) -> bool:
    return (
        isinstance(name, str)
        and 0 < len(name) <= 48
        and name.isascii()
        and (name[0].isalpha() or name[0] == "_")
        and name.replace("_", "a").isalnum()
    )


def _dense(a: object, what: str, where: str) -> np.ndarray:
    """A real square matrix as a dense float array (sparse accepted)."""
    if scipy.sparse.issparse(a):
        if a.shape[0] > MAX_DOFS:
            raise ModelError(f"{where}: {what} has {a.shape[0]} rows; at most {MAX_DOFS} DOFs are allowed")
        a = a.toarray()
    try:
        arr = np.asarray(a)
    except Exception:  # noqa: BLE001 - any object a user may pass
        raise ModelError(f"{where}: {what} is not an array") from None
    if arr.dtype.kind not in "biuf":
        raise ModelError(f"{where}: {what} must be a real numeric matrix, got dtype {arr.dtype}")
    if arr.ndim != 2 or arr.shape[0] != arr.shape[1] or arr.shape[0] == 0:
        raise ModelError(f"{where}: {what} must be a square matrix, got shape {arr.shape}")
    if arr.shape[0] > MAX_DOFS:
        raise ModelError(f"{where}: {what} has {arr.shape[0]} rows; at most {MAX_DOFS} DOFs are allowed")
    arr = arr.astype(float)
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{where}: {what} has entries that are not finite (nan or inf)")
    return arr


def _symmetric(a: np.ndarray, what: str, where: str) -> np.ndarray:
    scale = float(np.max(np.abs(a))) or 1.0
    asym = float(np.max(np.abs(a - a.T)))
    if asym > SYMMETRY_TOL * scale:
        i, j = np.unravel_index(int(np.argmax(np.abs(a - a.T))), a.shape)
        raise ModelError(
            f"{where}: {what} is not symmetric: {what}[{i},{j}] = {a[i, j]!r} but {what}[{j},{i}] = "
            f"{a[j, i]!r} (relative difference {asym / scale:.2g} > {SYMMETRY_TOL:g}); give the symmetric "
            "matrix of a linear elastic structure"
        )
    return 0.5 * (a + a.T)


@dataclass(frozen=True, eq=False)
class Structure:
    """A linear structure ``M q'' + C q' + K q = f`` over named DOFs.

    Build it with :meth:`from_arrays` (which checks it) or read it with :func:`read_matrices`.

    Attributes
    ----------
    M, K : ndarray, shape (n, n)
        Mass [kg] and stiffness [N/m] matrices (SI assumed; rotational DOFs in [kg m^2], [N m/rad]).
    C : ndarray, shape (n, n)
        Damping matrix [N s/m] (zeros if undamped).
    dofs : tuple of str
        The DOF names (identifiers, unique).
    source : str
        Where it comes from (a file, or ``"arrays"``), for messages.
    """

    M: np.ndarray
    K: np.ndarray
    C: np.ndarray
    dofs: tuple
    source: str = "arrays"

    @classmethod
    def from_arrays(
        cls,
        M: object,
        K: object,
        dofs: Sequence[str],
        C: object | None = None,
        *,
        rayleigh: Sequence[float] | None = None,
        modal_damping: Sequence[float] | None = None,
        source: str = "arrays",
    ) -> Structure:
        """A checked structure from matrices (dense arrays or scipy sparse matrices).

        Parameters
        ----------
        M, K : array_like or sparse, shape (n, n)
            Mass [kg] and stiffness [N/m] matrices.
        dofs : sequence of str
            ``n`` unique names (letters, digits, ``_``; not starting with a digit).
        C : array_like or sparse, optional
            Damping matrix [N s/m].
        rayleigh : (a, b), optional
            ``C = a M + b K`` (``a`` [1/s], ``b`` [s]).
        modal_damping : sequence of float, optional
            Damping ratios of the lowest modes (the last one for every mode above).
        source : str
            Named in error messages (e.g. the file).

        Raises
        ------
        ModelError
            Not square, sizes disagree, not finite, not symmetric, ``M`` not positive definite,
            ``K`` or ``C`` not positive semi-definite, bad or repeated names, two dampings given.
        """
        where = source
        M = _symmetric(_dense(M, "M", where), "M", where)
        K = _symmetric(_dense(K, "K", where), "K", where)
        n = M.shape[0]
        if K.shape != M.shape:
            raise ModelError(f"{where}: M is {M.shape[0]}x{M.shape[0]} but K is {K.shape[0]}x{K.shape[0]}")
        names = _dof_names(dofs, n, where)
        try:
            np.linalg.cholesky(M)
        except np.linalg.LinAlgError:
            lo = float(np.linalg.eigvalsh(M)[0])
            raise ModelError(
                f"{where}: M is not positive definite (smallest eigenvalue {lo:.3g}); every DOF needs "
                "mass (condense massless DOFs out, or reduce by Craig-Bampton)"
            ) from None
        _semidefinite(K, "K", where)
        given = [
            k
            for k, v in (("C", C), ("rayleigh", rayleigh), ("modal_damping", modal_damping))
            if v is not None
        ]
        if len(given) > 1:
            raise ModelError(f"{where}: give one damping, not {' and '.join(given)}")
        if C is not None:
            Cm = _symmetric(_dense(C, "C", where), "C", where)
            if Cm.shape != M.shape:
                raise ModelError(f"{where}: M is {n}x{n} but C is {Cm.shape[0]}x{Cm.shape[0]}")
            _semidefinite(Cm, "C", where)
        else:
            Cm = np.zeros_like(M)
        out = cls(M, K, Cm, names, source)
        if rayleigh is not None:
            out = out.with_damping(_rayleigh_matrix(out, rayleigh, where))
        if modal_damping is not None:
            out = out.with_damping(_modal_matrix(out, modal_damping, where))
        return out

    @property
    def n(self) -> int:
        """Number of DOFs."""
        return len(self.dofs)

    def with_damping(self, C: np.ndarray) -> Structure:
        """The same structure with the damping matrix ``C`` [N s/m]."""
        return Structure(self.M, self.K, np.asarray(C, float), self.dofs, self.source)

    def frequencies(self, count: int | None = None) -> np.ndarray:
        """Undamped natural frequencies [rad/s], ascending (:func:`natural_frequencies`)."""
        return natural_frequencies(self.M, self.K, count)


def _dof_names(dofs: object, n: int, where: str) -> tuple[str, ...]:
    if isinstance(dofs, str) or not isinstance(dofs, Sequence | np.ndarray):
        raise ModelError(f"{where}: dofs must be a list of {n} names, got {type(dofs).__name__}")
    names = [str(d).strip() if isinstance(d, str | np.str_) else d for d in list(dofs)]
    if len(names) != n:
        raise ModelError(
            f"{where}: {len(names)} DOF names for {n} DOFs (M is {n}x{n}); give one name per row"
        )
    bad = [d for d in names if not _valid_dof(d)]
    if bad:
        raise ModelError(
            f"{where}: DOF name {bad[0]!r:.60} is not valid (1 to 48 letters, digits and _, not starting "
            "with a digit)"
        )
    seen: set[str] = set()
    for d in names:
        if d in seen:
            raise ModelError(f"{where}: the DOF name `{d}` is given twice; DOF names must be unique")
        seen.add(d)
    return tuple(names)


def _semidefinite(a: np.ndarray, what: str, where: str) -> None:
    w = np.linalg.eigvalsh(a)
    scale = max(float(np.max(np.abs(w))), 1e-300)
    if w[0] < -1e-9 * scale:
        raise ModelError(
            f"{where}: {what} is not positive semi-definite (eigenvalue {w[0]:.3g}, largest {w[-1]:.3g}); "
            f"a passive structure's {what} has no negative eigenvalue"
        )


def natural_frequencies(M: np.ndarray, K: np.ndarray, count: int | None = None) -> np.ndarray:
    """Undamped natural frequencies ``sqrt(eig(K, M))`` [rad/s], ascending (rigid modes at 0).

    Parameters
    ----------
    M, K : ndarray, shape (n, n)
        Symmetric; ``M`` positive definite.
    count : int, optional
        Only the lowest ``count``.
    """
    sub = None if count is None else [0, min(count, M.shape[0]) - 1]
    w = scipy.linalg.eigh(K, M, eigvals_only=True, subset_by_index=sub)
    return np.sqrt(np.clip(w, 0.0, None))


def _rayleigh_matrix(s: Structure, ab: object, where: str) -> np.ndarray:
    if not (isinstance(ab, Sequence) and len(ab) == 2 and all(_real(v) for v in ab)):
        raise ModelError(f"{where}: `rayleigh` must be two numbers [a, b] (C = a M + b K), got {ab!r:.60}")
    a, b = float(ab[0]), float(ab[1])
    if a < 0 or b < 0:
        raise ModelError(f"{where}: `rayleigh` = [{a!r}, {b!r}]: both coefficients must be >= 0")
    return rayleigh(s.M, s.K, a, b)


def _modal_matrix(s: Structure, ratios: object, where: str) -> np.ndarray:
    if not (isinstance(ratios, Sequence) and 0 < len(ratios) <= s.n and all(_real(v) for v in ratios)):
        raise ModelError(
            f"{where}: `modal_damping` must be a list of 1 to {s.n} damping ratios (the lowest modes; "
            f"the last one for the modes above), got {ratios!r:.60}"
        )
    z = [float(v) for v in ratios]
    if any(v < 0 for v in z):
        raise ModelError(f"{where}: `modal_damping` ratios must be >= 0, got {z!r:.60}")
    return modal_damping(s.M, s.K, z)


def _real(v: object) -> bool:
    return (
        isinstance(v, int | float | np.floating | np.integer) and not isinstance(v, bool) and math.isfinite(v)
    )


def rayleigh(M: np.ndarray, K: np.ndarray, a: float, b: float) -> np.ndarray:
    """Rayleigh damping ``C = a M + b K`` [N s/m] (``a`` [1/s], ``b`` [s])."""
    return a * np.asarray(M, float) + b * np.asarray(K, float)


def modal_damping(M: np.ndarray, K: np.ndarray, ratios: Sequence[float]) -> np.ndarray:
    """The damping matrix giving mode ``k`` the ratio ``ratios[k]`` (the last for the modes above).

    ``C = M Phi diag(2 zeta_k omega_k) Phi^T M`` with ``Phi`` the mass-normalised modes, so that
    ``Phi^T C Phi = diag(2 zeta_k omega_k)`` [N s/m].
    """
    w2, phi = scipy.linalg.eigh(K, M)
    omega = np.sqrt(np.clip(w2, 0.0, None))
    z = np.asarray(list(ratios) + [ratios[-1]] * (len(omega) - len(ratios)), float)[: len(omega)]
    mp = M @ phi
    C = mp @ np.diag(2.0 * z * omega) @ mp.T
    return 0.5 * (C + C.T)


# ----------------------------------------------------------------------------
# Files
# ----------------------------------------------------------------------------
def _check_file(path: Path, what: str, where: str) -> None:
    if not path.exists():
        raise ModelError(
            f"{where}: the {what} {str(path)!r} does not exist (paths are relative to the model file)"
        )
    if path.is_file() and path.stat().st_size > MAX_MATRIX_BYTES:
        raise ModelError(f"{where}: {str(path)!r} has more than {MAX_MATRIX_BYTES} bytes")


def read_matrices(
    path: str | Path,
    *,
    dofs: Sequence[str] | None = None,
    rayleigh: Sequence[float] | None = None,
    modal_damping: Sequence[float] | None = None,
    where: str = "",
) -> Structure:
    """Read a structure's matrices from a ``.npz``, a ``.mat`` or a directory of ``.mtx`` files.

    Parameters
    ----------
    path : str or Path
        The file or directory (see the module docstring for what each holds).
    dofs : sequence of str, optional
        The DOF names, where the file holds none (or to replace them).
    rayleigh, modal_damping : optional
        As for :meth:`Structure.from_arrays` (the file must then hold no ``C``).
    where : str
        Prefix of error messages (e.g. ``"[structures.beam]"``).

    Raises
    ------
    ModelError
        The file is missing, unreadable, of another kind, lacks ``M`` or ``K`` or the names, or
        the matrices fail the checks of :meth:`Structure.from_arrays`; the message names the file
        and the array.
    """
    path = Path(path)
    at = f"{where} {str(path)!r}".strip()
    _check_file(path, "matrix file", where)
    if path.is_dir():
        arrays = _read_mtx_dir(path, at)
    elif path.suffix.lower() == ".npz":
        arrays = _read_npz(path, at)
    elif path.suffix.lower() == ".mat":
        arrays = _read_mat(path, at)
    else:
        raise ModelError(
            f"{at}: unknown kind of matrix file {path.suffix!r}; give a .npz, a .mat, or a directory "
            "holding M.mtx, K.mtx (C.mtx) and dofs.txt"
        )
    for key in ("M", "K"):
        if key not in arrays:
            raise ModelError(f"{at}: no array `{key}` (found: {', '.join(sorted(arrays)) or 'none'})")
    names = dofs if dofs is not None else arrays.get("dofs")
    if names is None:
        raise ModelError(
            f"{at}: no DOF names: add an array `dofs` of strings to the file (dofs.txt beside .mtx files), "
            "or give `dofs = [...]` in the structure's table"
        )
    if "C" in arrays and (rayleigh is not None or modal_damping is not None):
        raise ModelError(
            f"{at}: the file holds a damping matrix C; do not also give `rayleigh` or `modal_damping`"
        )
    return Structure.from_arrays(
        arrays["M"],
        arrays["K"],
        names,
        arrays.get("C"),
        rayleigh=rayleigh,
        modal_damping=modal_damping,
        source=at,
    )


def _read_npz(path: Path, at: str) -> dict:
    try:
        with np.load(path, allow_pickle=False) as z:
            out = {k: z[k] for k in z.files if k in ("M", "K", "C", "dofs")}
    except ValueError as exc:
        raise ModelError(f"{at}: cannot be read as a .npz of plain arrays ({exc})") from None
    except (OSError, EOFError) as exc:
        raise ModelError(f"{at}: cannot be read as a .npz ({exc})") from None
    if "dofs" in out:
        if out["dofs"].dtype.kind not in "US":
            raise ModelError(f"{at}: array `dofs` must hold strings, got dtype {out['dofs'].dtype}")
        out["dofs"] = [str(d) for d in np.ravel(out["dofs"])]
    return out


def _read_mat(path: Path, at: str) -> dict:
    try:
        raw = scipy.io.loadmat(str(path))
    except (ValueError, OSError, TypeError, NotImplementedError) as exc:
        raise ModelError(f"{at}: cannot be read as a MATLAB .mat file, version 4 to 7.2 ({exc})") from None
    out = {k: raw[k] for k in ("M", "K", "C") if k in raw}
    if "dofs" in raw:
        d = raw["dofs"]
        if d.dtype.kind in "US":  # a char matrix: one padded row per name
            out["dofs"] = [str(s).strip() for s in np.ravel(d)]
        elif d.dtype == object:  # a cell array of strings
            out["dofs"] = [str(np.ravel(c)[0]) if np.size(c) else "" for c in np.ravel(d)]
        else:
            raise ModelError(f"{at}: variable `dofs` must be a char matrix or a cell array of strings")
    return out


def _read_mtx_dir(path: Path, at: str) -> dict:
    out: dict = {}
    for key in ("M", "K", "C"):
        f = path / f"{key}.mtx"
        if not f.exists():
            continue
        _check_file(f, "MatrixMarket file", at)
        try:
            out[key] = scipy.io.mmread(str(f))
        except (ValueError, OSError, IndexError, TypeError) as exc:
            raise ModelError(f"{at}: {key}.mtx cannot be read as MatrixMarket ({exc})") from None
    names = path / "dofs.txt"
    if names.exists():
        _check_file(names, "DOF list", at)
        try:
            text = names.read_text("utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise ModelError(f"{at}: dofs.txt cannot be read as UTF-8 text ({exc})") from None
        out["dofs"] = [line.strip() for line in text.splitlines() if line.strip()]
    return out
