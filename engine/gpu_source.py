"""The CUDA kernel's source, generated per scene (engine.gpu compiles it): one thread a
point, its scratch and its copy of the settings record in local memory with literal shapes
(``cuda.local.array`` wants them), then the scene's own ``run_point``."""
from __future__ import annotations

import os

from . import params as P
from .integrators.problem import CONFIG, CTR_SIZE

COLS = (P.W, P.OMEGA, P.V_REF, P.VD)   # the grid columns a thread writes into its p


def simulated() -> bool:
    """True under numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``)."""
    return os.environ.get("NUMBA_ENABLE_CUDASIM", "") not in ("", "0")


def _alloc_lines(shapes, prefix: str) -> tuple[list[str], str]:
    """Source lines allocating and zeroing local arrays shaped as ``shapes`` (nested
    tuples, leaves are shape tuples), and the expression of the nested tuple."""
    if shapes and isinstance(shapes[0], int):        # a leaf: one array
        name = f"w{prefix}"
        lines = [f"{name} = cuda.local.array({tuple(shapes)!r}, float64)"]
        idx = ", ".join(f"i{d}" for d in range(len(shapes)))
        indent = ""
        for d, size in enumerate(shapes):
            lines.append(f"{indent}for i{d} in range({size}):")
            indent += "    "
        lines.append(f"{indent}{name}[{idx}] = 0.0")
        return lines, name
    lines, parts = [], []
    for k, sub in enumerate(shapes):
        sub_lines, expr = _alloc_lines(sub, f"{prefix}_{k}")
        lines += sub_lines
        parts.append(expr)
    return lines, "(" + ", ".join(parts) + ("," if len(parts) == 1 else "") + ")"


def _simulator_array(a):
    """The numpy array behind a simulated device array (the simulator wraps the kernel's
    arguments; the engine's njit functions take numpy arrays)."""
    item = a.__dict__.get("_item") if hasattr(a, "__dict__") else None
    return item._ary if item is not None else a


def _config_copy_lines(dst: str, src: str) -> str:
    """Source copying the settings record ``src[0]`` into ``dst[0]`` field by field (every
    thread its own copy in its local memory: the driver writes the point's fixed step and
    tolerances into it; one record on the device for the whole launch, not one a point
    copied from the host: 656 bytes a point, 688 MB and ~1 s of numpy for a million)."""
    lines = []
    for name in CONFIG.names:
        shape = CONFIG.fields[name][0].shape
        assert len(shape) <= 1, f"CONFIG.{name}: a copy of scalars and 1-D fields only"
        if shape:
            lines.append(f"    for i in range({shape[0]}):")
            lines.append(f"        {dst}[0][{name!r}][i] = {src}[0][{name!r}][i]")
        else:
            lines.append(f"    {dst}[0][{name!r}] = {src}[0][{name!r}]")
    return "\n".join(lines)


def kernel_source(shapes, n: int, obs_size: int, n_out: int, n_params: int,
                  simulator: bool = False) -> str:
    """The CUDA kernel's Python source for one scene (sizes and shapes as literals).
    ``simulator``: unwrap the simulator's device arrays before the engine's calls."""
    alloc, work = _alloc_lines(shapes, "")
    body = "\n".join("    " + line for line in alloc)
    host = "host" if simulator else ""
    return f'''
def block(points, p, cfg0, rec, out, status, counters):
    j = cuda.grid(1)
    if j >= points.shape[0]:
        return
    cfg = cuda.local.array(1, CONFIG_T{"" if simulator else ", alignment=8"})
{_config_copy_lines("cfg", "cfg0")}
    q = cuda.local.array({n_params}, float64)
    for i in range({n_params}):
        q[i] = p[i]
    for c in range(4):
        q[COLS[c]] = points[j, c]
    y = cuda.local.array({n}, float64)
    obs = cuda.local.array({max(obs_size, 1)}, float64)
    o = cuda.local.array({n_out}, float64)
    ctr = cuda.local.array({CTR_SIZE}, int64)
{body}
    status[j] = run_point(q, {host}(cfg), {work}, y, obs[:{obs_size}], o, ctr,
                          {host}(rec))
    for c in range({n_out}):
        out[j, c] = o[c]
    for c in range(3):
        counters[j, c] = ctr[c]
'''


def kernel_namespace(pk) -> dict:
    """The globals of a scene's kernel source: numba.cuda, the types, the grid columns
    and the scene's ``run_point`` (engine.kernels.PointKernel ``pk``)."""
    from numba import cuda, float64, int64
    from numba.np.numpy_support import from_dtype

    config_t = CONFIG if simulated() else from_dtype(CONFIG)   # (the simulator: numpy's)
    return {"cuda": cuda, "float64": float64, "int64": int64, "COLS": COLS,
            "CONFIG_T": config_t,
            "run_point": pk.run_point, "host": _simulator_array}
