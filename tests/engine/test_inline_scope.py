"""numba's IR inliner copies a callee's scope once per copy, not once per block
(engine.inline_scope).

No clock: the tests count the copies of the callee's scope while numba inlines it, and
compare what the caller compiles to with and without the change.
"""
import copy
import re

import numba
from numba.core import inline_closurecall, ir

from engine import inline_scope, jit  # noqa: F401 -- importing engine.jit installs it


def _branchy(x):
    """Many blocks and variables, as the engine's step loop has."""
    a = x + 1.0
    if a > 2.0:
        a = a * 2.0
    b = a - 3.0
    if b < 0.0:
        b = -b
    c = a * b
    for i in range(3):
        if c > 10.0:
            c = c - i
        else:
            c = c + i
    d = c / 2.0 if c != 0.0 else 1.0
    return a + b + c + d


def _caller_of(inlined):
    def caller(x):
        return inlined(x) + inlined(x + 1.0)
    return numba.njit(caller)


def _compile(sig=(numba.float64,)):
    """A fresh caller with a fresh inlined callee, compiled: the copies of the callee's
    scope made, the caller's value at 0.5 and its optimised LLVM IR."""
    callee = numba.njit(inline="always")(_branchy)
    caller = _caller_of(callee)
    copies = []
    original = getattr(ir.Scope, "__deepcopy__", None)

    def counted(self, memo):
        if self.parent is not None:   # (a function's scope, not the global one above it)
            copies.append(self)
        new = type(self).__new__(type(self))
        memo[id(self)] = new
        new.__dict__.update(copy.deepcopy(self.__dict__, memo))
        return new

    ir.Scope.__deepcopy__ = counted
    try:
        caller.compile(sig)
    finally:
        if original is None:
            del ir.Scope.__deepcopy__
        else:
            ir.Scope.__deepcopy__ = original
    text = caller.inspect_llvm(sig)
    # masked: the symbols and the inlined variables' names carry per-process counters
    return len(copies), caller(0.5), re.sub(r'_ZN[\w$.]+|"[^"]*"|_v\d+_', "_", text)


def _without(monkeypatch):
    monkeypatch.setattr(inline_closurecall.InlineWorker, "inline_ir",
                        inline_closurecall.InlineWorker.inline_ir.__wrapped__)
    monkeypatch.delattr(ir.Block, "__deepcopy__")


def test_it_is_installed_on_numba_s_inliner():
    worker = inline_closurecall.InlineWorker.inline_ir
    assert getattr(worker, "_ditherlab", False), "numba's InlineWorker.inline_ir moved"
    assert ir.Block.__deepcopy__ is inline_scope._copy_block
    inline_scope.install()   # idempotent
    assert inline_closurecall.InlineWorker.inline_ir is worker


def test_each_inlined_call_copies_the_scope_twice_not_once_per_block(monkeypatch):
    shared, value, text = _compile()
    # two calls inlined, two IR copies each (inline_ir's working copy and its original)
    assert shared == 4, shared
    _without(monkeypatch)
    per_block, plain_value, plain_text = _compile()
    assert per_block > 4 * shared, (shared, per_block)   # (numba's: one per block)
    assert value == plain_value == _branchy(0.5) + _branchy(1.5)
    assert text == plain_text


def test_a_block_copied_elsewhere_is_copied_whole():
    """Outside inline_ir a block's deepcopy is numba's own: its scope copied with it."""
    scope = ir.Scope(None, ir.Loc("f.py", 1))
    var = scope.define("x", ir.Loc("f.py", 1))
    block = ir.Block(scope, ir.Loc("f.py", 1))
    block.append(ir.Del(var.name, ir.Loc("f.py", 1)))
    twin = copy.deepcopy(block)
    assert twin is not block and twin.scope is not scope
    assert twin.scope.get("x").name == "x" and twin.body[0].value == "x"


def test_only_the_callee_s_scope_is_shared():
    """While inline_ir runs, the callee's blocks (and its copy's) share one scope copy; a
    block of another function copied meanwhile (a compile inline_ir starts) is copied as
    numba does, its scope with it (a review of 33cdc22)."""
    loc = ir.Loc("f.py", 1)
    callee, other = ir.Scope(None, loc), ir.Scope(None, loc)
    blocks = [ir.Block(s, loc) for s in (callee, callee, other, other)]
    inline_scope._SHARED.scopes = {id(callee): None}
    try:
        a, b, c, d = (copy.deepcopy(x) for x in blocks)
        again = copy.deepcopy(a)   # (inline_ir copies its working copy once more)
        again_b = copy.deepcopy(b)
    finally:
        inline_scope._SHARED.scopes = None
    assert a.scope is b.scope and a.scope is not callee
    assert c.scope is not d.scope and c.scope is not other and d.scope is not other
    assert again.scope is not a.scope and again_b.scope is again.scope
