"""Run-time numerical settings of an integration (not compile-time: no recompilation)."""
from __future__ import annotations

from dataclasses import asdict, dataclass

ATOL_UNITS = ("absolute", "natural")
DEVICES = ("cpu", "cuda")   # where a block is integrated (engine.blocks.run_block)


@dataclass(frozen=True)
class Settings:
    """Step and tolerance policy of one run.

    Attributes
    ----------
    rtol, atol
        Adaptive methods: relative and absolute local error tolerances.
    atol_units
        ``"absolute"``: ``atol`` is the absolute tolerance of every state component.
        ``"natural"``: component ``i`` gets ``atol * scale_i``, its natural scale (the
        system's ``scales``: slider ``e ~ fc``, ``v ~ max(|v_ref|, W)``, ``z ~ fc /
        sigma0``; contact ``z ~ fc / sigma0``), so that a bristle deflection of 1e-6 at
        sigma0 = 1e6, or a creep velocity of 1e-6, is held to the same *relative* accuracy
        as the spring force -- one scalar ``atol`` cannot do both.
    steps_per_period
        Fixed-step methods: steps per square-wave half-period, or per dither period
        for a sine, so that the step divides the waveform period exactly.
    h
        Fixed-step methods without dither: the step (time units).
    max_steps
        Budget of accepted + rejected steps per point; past it the point is FAILED.
    device
        ``"cpu"`` (the calling thread) or ``"cuda"`` (an NVIDIA GPU, one thread a point:
        engine.gpu; numbers agree with the CPU's within the tolerances, not bit for bit).
    """

    rtol: float = 1e-6
    atol: float = 1e-8
    atol_units: str = "absolute"
    steps_per_period: int = 8
    h: float = 1e-3
    max_steps: int = 50_000_000
    device: str = "cpu"

    def __post_init__(self):
        if self.atol_units not in ATOL_UNITS:
            raise ValueError(f"atol_units: {self.atol_units!r} is not one of {ATOL_UNITS}")
        if self.device not in DEVICES:
            raise ValueError(f"device: expected one of {DEVICES}, got {self.device!r}")

    def as_dict(self) -> dict:
        return asdict(self)
