"""numba's IR inliner copies a callee's scope once, not once per block.

The engine inlines its step loop and a method's small parts into the driver (numba's
``inline="always"``: a call per step cost DP5 15 %, engine.integrators.adaptive). To inline
a call, numba's ``InlineWorker.inline_ir`` copies the callee's IR twice (a copy it mutates
and an unmutated one it returns), each block by its own ``copy.deepcopy`` with a fresh memo.
Every block refers to the function's one ``Scope``, and the scope holds every variable of
the function with its location. So each block copied the whole scope again: work in blocks
times variables, per inlined call. Two thirds of the inlining's time went to ``deepcopy``
(``cProfile``: 670,000 calls for the cheap sweep's scene, 35 inlined calls), and the driver
with its inlined step loop took 1.70 s of that scene's 5.7 s first compile.

:func:`install` wraps ``inline_ir`` so that, while it runs, the blocks copied from one scope
share one copy of it: their ``Var``\\ s point to it, as the original blocks' point to the
original scope. Only the callee's scope and its copy are shared so; a block of another
function copied meanwhile (a compile that ``inline_ir`` starts) is copied as numba does.
numba itself used only the first block's copy (``_get_all_scopes`` compares the copies by
value and finds one; it renames the variables in that one), the others were dropped when
the inlined blocks join the caller's scope. Everything else in a block is copied as before.
The optimised LLVM IR and the machine code of the block kernels of the cheap scene, Fig.
10's, Fig. 14's and docs/examples/servo-gms.toml's are the same with and without it; the
driver's compile took 1.16 s (docs/PERFORMANCE.md).

numba internals (pinned to 0.68 in pyproject.toml): tests/engine/test_inline_scope.py fails
if ``inline_ir`` moves or stops copying through ``ir.Block``.
"""
from __future__ import annotations

import copy
import threading

_SHARED = threading.local()   # while inline_ir runs: {id(scope): None or (scope, its copy)}


def _copy_block(block, memo):
    """``copy.deepcopy`` of an ``ir.Block`` (what deepcopy does for a plain object: a new
    instance, its ``__dict__`` copied), seeded inside ``inline_ir`` with its scope's copy."""
    shared = getattr(_SHARED, "scopes", None)
    scope = block.scope
    if shared is not None and id(scope) in shared:   # (the callee's scope, or its copy)
        pair = shared[id(scope)]
        if pair is None:   # (the scope itself kept in the pair: its id stays unique)
            pair = shared[id(scope)] = (scope, copy.deepcopy(scope))
            shared.setdefault(id(pair[1]), None)   # (copied again: the unmutated copy)
        memo.setdefault(id(scope), pair[1])
    new = type(block).__new__(type(block))
    memo[id(block)] = new
    new.__dict__.update(copy.deepcopy(block.__dict__, memo))
    return new


def install() -> None:
    """Share one scope copy per copied IR in numba's ``InlineWorker.inline_ir``."""
    from numba.core import inline_closurecall, ir

    worker = inline_closurecall.InlineWorker
    original = worker.inline_ir
    if getattr(original, "_ditherlab", False) or "__deepcopy__" in vars(ir.Block):
        return   # (installed, or numba copies its blocks its own way now: left alone)

    def inline_ir(self, *args, **kws):
        callee = args[3] if len(args) > 3 else kws["callee_ir"]
        outer = getattr(_SHARED, "scopes", None)
        # only the callee's scopes: a compile inside inline_ir (numba types an overload it
        # inlines) copies its own blocks as numba does, each copy with its scope as it is then
        _SHARED.scopes = {id(b.scope): None for b in callee.blocks.values()}
        try:
            return original(self, *args, **kws)
        finally:
            _SHARED.scopes = outer

    inline_ir._ditherlab = True
    inline_ir.__wrapped__ = original
    worker.inline_ir = inline_ir
    ir.Block.__deepcopy__ = _copy_block
