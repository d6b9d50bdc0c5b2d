"""The built gait NLP kept on disk: nlpsol's problem and IPOPT's derivative functions (issue 28).

Building the paper's case (38 knots) costs ~0.5 s of CPU even with the block kinds' derivatives
compiled (nlp_codegen.py): the SX graph built in Python (~0.15 s), the kinds' instances mapped
and gathered, the rest of the constraints and the cost differentiated (~0.1 s), nlpsol. The
result is four casadi Functions (the problem (x, p) -> (f, g), grad_f, jac_g, hess_lag) and the
layout of the variables and rows; casadi serialises Functions with its own serializer
(FileSerializer; pickle cannot), so a later build of the same problem loads them (~0.25 s)
instead, and skips the graph altogether. The compiled kinds inside are External functions: the
file refers to their libraries in the codegen cache, so a missing library makes the load fail
and the problem is built as before.

Key: the SHA-256 of what the NLP is made of, known before building it: the planar model's SX
functions (casadi's serialisation: the robot's numbers), its leg joints, the knots, the
baseline flag, the Hessian (exact or not), the casadi version, CACHE_VERSION and the source of
the modules that build the NLP (a change in any of them is a new key). Entries are written
only by an explicit request (`GaitProblem(compile_derivatives=True)`, the bench) and only for a
problem whose kinds all had compiled derivatives: a sweep over robot variants would pay the
write (~0.3 s) per variant for nothing. Folder: the codegen cache's (nlp_codegen.cache_folder,
`BIPED_STUDIO_CODEGEN_CACHE=off` turns both off), one `nlp-<key>` folder per problem, renamed
into place only once complete.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import logging
import os
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np

from app.core.collocation import nlp_codegen
from app.core.collocation.nlp_ipopt import CompiledNlp, IpoptCallback

if TYPE_CHECKING:
    from app.core.collocation.nlp import SxNlp
    from app.core.collocation.planar_model import PlanarModel

CACHE_VERSION = 1
"""What the entries hold and how: bump on change."""
SOURCES = (
    "gait_nlp.py",
    "transcription.py",
    "nlp.py",
    "nlp_blocks.py",
    "nlp_codegen.py",
    "nlp_ipopt.py",
    "nlp_cache.py",
)
"""The modules (app/core/collocation) whose code makes the cached functions."""
FUNCTIONS = "functions.casadi"
LAYOUT = "layout.json"
BOUNDS = "bounds.npz"
ORDER = ("oracle", "grad_f", "jac_g", "hess_lag")
"""The functions' order in FUNCTIONS."""
MODEL_FUNCTIONS = ("rnea", "mass_matrix", "contact_positions", "contact_jacobian", "contact_jdot_v")

_log = logging.getLogger(__name__)


@dataclasses.dataclass(frozen=True)
class SavedNlp:
    """A built NLP read back: its functions and the layout of its variables and rows."""

    oracle: ca.Function
    derivatives: dict[str, ca.Function]
    x_blocks: dict[str, list[slice]]
    g_blocks: dict[str, list[slice]]
    p_index: dict[str, int]
    knot_swing: list[slice]
    lbg: np.ndarray
    ubg: np.ndarray

    @property
    def nx(self) -> int:
        return int(self.oracle.size1_in(0))

    @property
    def ng(self) -> int:
        return int(self.lbg.size)

    def compile(self, options: dict[str, Any]) -> CompiledNlp:
        """The IPOPT solver pair on these functions (as SxNlp.compile makes it)."""
        callback = IpoptCallback(self.nx, self.ng)
        options = {**options, "iteration_callback": callback, **self.derivatives}
        solver = ca.nlpsol("gait", "ipopt", self.oracle, options)
        return CompiledNlp(
            solver=solver,
            callback=callback,
            lbg=self.lbg.copy(),
            ubg=self.ubg.copy(),
            problem=None,
            options=options,
            derivatives=dict(self.derivatives),
            oracle=self.oracle,
        )


def problem_key(model: PlanarModel, knots: int, baseline: bool, exact_hessian: bool) -> str:
    """The cache key of the gait NLP of `model` at this structure (see the module's text)."""
    digest = hashlib.sha256()
    here = Path(__file__).parent
    for part in (
        ca.CasadiMeta.version(),
        str(CACHE_VERSION),
        repr((knots, baseline, exact_hessian)),
        repr(
            sorted(
                (side, tuple(int(j) for j in joints)) for side, joints in model.leg_joints.items()
            )
        ),
        repr((model.nq, model.nv, model.nu)),
    ):
        digest.update(part.encode("utf-8") + b"\0")
    for name in SOURCES:
        digest.update((here / name).read_bytes() + b"\0")
    for name in MODEL_FUNCTIONS:
        digest.update(getattr(model, name).serialize().encode("utf-8") + b"\0")
    return digest.hexdigest()[:32]


def _folder(key: str) -> Path | None:
    root = nlp_codegen.cache_folder()
    return None if root is None else root / f"nlp-{key}"


def load(key: str) -> SavedNlp | None:
    """The NLP saved under `key`; None when the cache is off, has no entry, or the entry cannot
    be read (a compiled kind's library gone, another casadi: then it is built as before)."""
    where = _folder(key)
    if where is None or not (where / FUNCTIONS).is_file():
        return None
    try:
        layout = json.loads((where / LAYOUT).read_text(encoding="utf-8"))
        with np.load(where / BOUNDS) as bounds:
            lbg, ubg = bounds["lbg"], bounds["ubg"]
        reader = ca.FileDeserializer(str(where / FUNCTIONS))
        functions = {name: reader.unpack() for name in ORDER[: layout["functions"]]}
    except (OSError, RuntimeError, KeyError, ValueError) as error:
        _log.warning("the saved gait NLP in %s was not loaded (%s): building it", where, error)
        return None
    oracle = functions.pop("oracle")
    return SavedNlp(
        oracle=oracle,
        derivatives=functions,
        x_blocks=_slices(layout["x_blocks"]),
        g_blocks=_slices(layout["g_blocks"]),
        p_index={name: int(i) for name, i in layout["p_index"].items()},
        knot_swing=[slice(a, b) for a, b in layout["knot_swing"]],
        lbg=lbg,
        ubg=ubg,
    )


def save(
    key: str,
    nlp: SxNlp,
    knot_swing: list[slice],
    compiled: CompiledNlp,
    *,
    require_compiled: bool = True,
) -> bool:
    """Write the built NLP under `key` (nothing when the cache is off or it is there);
    whether it is there now. Only a problem whose block kinds all use compiled derivatives
    is worth keeping (otherwise the next build would keep casadi's virtual machine), unless
    `require_compiled` is False (the tests, which do not pay ~35 s of compiling)."""
    where = _folder(key)
    if where is None or compiled.oracle is None or not isinstance(compiled.oracle, ca.Function):
        return False
    if (where / FUNCTIONS).is_file():
        return True
    if require_compiled and not (nlp.kinds and all(kind.loaded for kind in nlp.kinds)):
        return False
    names = [name for name in ORDER[1:] if name in compiled.derivatives]
    layout = {
        "functions": 1 + len(names),
        "x_blocks": _spans(nlp.x_blocks),
        "g_blocks": _spans(nlp.g_blocks),
        "p_index": nlp.p_index,
        "knot_swing": [[s.start, s.stop] for s in knot_swing],
    }
    try:
        where.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(dir=where.parent) as scratch:
            folder = Path(scratch) / "entry"
            folder.mkdir()
            writer = ca.FileSerializer(str(folder / FUNCTIONS))
            writer.pack(compiled.oracle)
            for name in names:
                writer.pack(compiled.derivatives[name])
            del writer  # closes the file
            (folder / LAYOUT).write_text(json.dumps(layout), encoding="utf-8")
            np.savez(folder / BOUNDS, allow_pickle=False, lbg=compiled.lbg, ubg=compiled.ubg)
            with contextlib.suppress(OSError):  # written meanwhile by another process
                os.rename(folder, where)
    except OSError as error:
        _log.warning("the gait NLP could not be saved in %s: %s", where, error)
        return False
    return (where / FUNCTIONS).is_file()


def _spans(blocks: dict[str, list[slice]]) -> dict[str, list[list[int]]]:
    return {name: [[s.start, s.stop] for s in slices] for name, slices in blocks.items()}


def _slices(spans: dict[str, list[list[int]]]) -> dict[str, list[slice]]:
    return {name: [slice(int(a), int(b)) for a, b in pairs] for name, pairs in spans.items()}
