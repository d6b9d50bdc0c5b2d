"""Compiled derivatives of the gait NLP's block kinds, cached on disk (issue 28).

A block kind's Jacobian and Lagrangian-Hessian functions (nlp_blocks.BlockKind) are SX
functions evaluated by casadi's virtual machine at every IPOPT iteration, over all of the kind's
instances (Function.map), and are derived symbolically at every build (ca.hessian, ca.jacobian:
about half of the derivative step). Here they are generated as C (casadi's CodeGenerator),
compiled once with gcc -O1 into a shared library, and loaded with `ca.external` by every later
build of a problem with the same kinds — in this process, the solver worker, each sweep worker,
the next session — which then skips their symbolic derivation too.

Key: the SHA-256 of the kind's constraint function (casadi's serialisation of its SX graph:
the robot's numbers, the collocation, the rows), which of its inputs are variables, the casadi
version, the compiler flags and CODEGEN_VERSION (bump it when the derivatives' construction in
nlp_blocks.py changes). One folder per key holds the library and the derivatives' sparsity.

A kind not in the cache is derived as before (virtual machine) and, with `compile_missing`,
compiled in a background thread (nice'd gcc, ~35 s of CPU for the six kinds of dircon_biped
at -O1), for the next build; the library appears under its final name only once complete.
Cache folder: $BIPED_STUDIO_CODEGEN_CACHE, else ~/.cache/biped-studio/gait-codegen;
BIPED_STUDIO_CODEGEN_CACHE=off turns the cache off.
"""

from __future__ import annotations

import hashlib
import logging
import os
import shutil
import subprocess
import tempfile
import threading
from pathlib import Path
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

if TYPE_CHECKING:
    from app.core.collocation.nlp_blocks import BlockKind

CODEGEN_VERSION = 1
"""The derivatives' construction (nlp_blocks.BlockKind.jacobian/hessian): bump on change."""
CACHE_ENV = "BIPED_STUDIO_CODEGEN_CACHE"
COMPILER = ("gcc", "-O1", "-shared", "-fPIC")
"""-O1: the functions run ~5× faster than casadi's virtual machine (-O0: 1.5×) at a third of
-O2's compile time."""
LIBRARY = "derivatives.so"
SPARSITY = "sparsity.npz"

_log = logging.getLogger(__name__)
_compiling: set[str] = set()
"""Keys being compiled in this process (one compile per key)."""
_compiling_lock = threading.Lock()


def cache_folder() -> Path | None:
    """Where compiled kinds are kept (None: the cache is off)."""
    value = os.environ.get(CACHE_ENV, "")
    if value.strip().lower() == "off":
        return None
    if value:
        return Path(value)
    return Path.home() / ".cache" / "biped-studio" / "gait-codegen"


def kind_key(kind: BlockKind) -> str:
    """The cache key of a block kind whose variables are classified."""
    digest = hashlib.sha256()
    for part in (
        ca.CasadiMeta.version(),
        str(CODEGEN_VERSION),
        " ".join(COMPILER),
        str(kind.variables),
    ):
        digest.update(part.encode("utf-8") + b"\0")
    digest.update(kind.function.serialize().encode("utf-8"))
    return digest.hexdigest()[:32]


def load_compiled(kind: BlockKind) -> bool:
    """Give `kind` its compiled derivatives from the cache; False when they are not there."""
    folder = cache_folder()
    if folder is None:
        return False
    where = folder / kind_key(kind)
    library, sparsity = where / LIBRARY, where / SPARSITY
    if not (library.is_file() and sparsity.is_file()):
        return False
    try:
        with np.load(sparsity) as data:
            jac_rc = (data["jac_r"], data["jac_c"])
            hess_rc = (data["hess_r"], data["hess_c"])
        jac = ca.external(f"{kind.name}_jac", str(library))
        hess = ca.external(f"{kind.name}_hess", str(library))
    except (OSError, RuntimeError, KeyError, ValueError) as error:
        _log.warning("compiled derivatives in %s not loaded (%s): deriving them", where, error)
        return False
    kind.set_derivatives((jac, *jac_rc), (hess, *hess_rc))
    return True


def compile_missing(kinds: list[BlockKind], *, wait: bool = False) -> threading.Thread | None:
    """Compile the kinds' derivatives into the cache (those not there yet), in a background
    thread named "gait-codegen" (joined first with `wait`). None when there is nothing to do,
    no cache or no compiler."""
    folder = cache_folder()
    if folder is None or shutil.which(COMPILER[0]) is None:
        return None
    todo = []
    with _compiling_lock:
        for kind in kinds:
            key = kind_key(kind)
            if key in _compiling or (folder / key / LIBRARY).is_file():
                continue
            _compiling.add(key)
            todo.append((key, kind))
    if not todo:
        return None
    # The C text and sparsity are made here (casadi objects stay in this thread); gcc runs in
    # the background.
    jobs = [(key, _source(kind), _sparsity(kind)) for key, kind in todo]
    thread = threading.Thread(
        target=_compile_all, args=(folder, jobs), name="gait-codegen", daemon=True
    )
    thread.start()
    if wait:
        thread.join()
    return thread


def _source(kind: BlockKind) -> str:
    generator = ca.CodeGenerator(f"{kind.name}.c", {"with_header": False})
    generator.add(kind.jacobian()[0])
    generator.add(kind.hessian()[0])
    return str(generator.dump())


def _sparsity(kind: BlockKind) -> dict[str, np.ndarray]:
    _, jac_r, jac_c = kind.jacobian()
    _, hess_r, hess_c = kind.hessian()
    return {"jac_r": jac_r, "jac_c": jac_c, "hess_r": hess_r, "hess_c": hess_c}


def _compile_all(folder: Path, jobs: list[tuple[str, str, dict[str, np.ndarray]]]) -> None:
    for key, source, sparsity in jobs:
        try:
            _compile_one(folder / key, source, sparsity)
        except (OSError, subprocess.CalledProcessError) as error:
            _log.warning("compiling the gait's derivatives (%s) failed: %s", key, error)
        finally:
            with _compiling_lock:
                _compiling.discard(key)


def _compile_one(where: Path, source: str, sparsity: dict[str, np.ndarray]) -> None:
    """gcc the source into where/LIBRARY; the library gets its name only when complete."""
    where.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=where) as scratch:
        c_file = Path(scratch) / "derivatives.c"
        c_file.write_text(source, encoding="utf-8")
        built = Path(scratch) / LIBRARY
        command = ["nice", "-n", "10", *COMPILER, str(c_file), "-o", str(built), "-lm"]
        subprocess.run(command, check=True, capture_output=True)
        np.savez(Path(scratch) / SPARSITY, allow_pickle=False, **sparsity)
        os.replace(Path(scratch) / SPARSITY, where / SPARSITY)
        os.replace(built, where / LIBRARY)
