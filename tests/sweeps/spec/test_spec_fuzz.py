"""Property: no mutation of a valid spec gets past validation, slows it or crashes it
(issue 10). Each generated spec, written as a TOML or JSON file (or raw bytes), must end in
a SpecError whose lines are short and name the field, and in exit status 2 from
``ditherlab plan`` / ``submit`` (``sweeps.cli.main`` in-process) with nothing written to
the store; the benign mutations must be accepted and plan. The mutations are the ones
``scripts/fuzz_spec.py`` runs by the thousand (tests/sweeps/spec/spec_mutations.py); this is
the CI-sized sample, drawn by hypothesis."""
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sweeps import cli
from sweeps.spec import load_spec, parse_spec

from .spec_cases import VALID, Case, bases, check
from .spec_mutations import MUTATIONS

BASES = bases()


def test_the_valid_bases_are_valid(tmp_path):
    for i, base in enumerate(BASES):
        for fmt in ("toml", "json"):
            case = Case("valid", base.get("name", "?"), "accept", base, fmt)
            path = tmp_path / f"base{i}.{fmt}"
            path.write_bytes(case.payload())
            assert load_spec(path).sweep_id == parse_spec(base).sweep_id
    assert VALID in BASES


@pytest.mark.parametrize("mutate", MUTATIONS, ids=lambda m: m.__name__)
def test_every_mutation_breaks_what_it_says(mutate, tmp_path):
    """One case of each mutation, from a fixed seed: each kind is covered whatever
    hypothesis draws below."""
    import random

    case = mutate(random.Random(1), VALID)
    res = check(case, tmp_path)
    assert res["faults"] == [], (case, res.get("lines"))


@pytest.mark.long
@settings(max_examples=60, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(st.sampled_from(MUTATIONS), st.sampled_from(range(len(BASES))),
       st.randoms(use_true_random=False))
def test_mutated_specs_are_refused_cleanly(mutate, base, rng):
    case = mutate(rng, BASES[base])
    with tempfile.TemporaryDirectory() as tmp:
        res = check(case, Path(tmp), commands=("plan", "submit"))
    assert res["faults"] == [], (case, res.get("lines"))


@pytest.mark.parametrize("command", ["plan", "submit"])
def test_cli_refuses_with_exit_2_and_writes_nothing(tmp_path, capsys, command):
    path = tmp_path / "bad.toml"
    path.write_text('name = "x"\naccuracy = { integrator = "euler" }\n[time]\nt_end = "100"\n'
                    "[grid]\nW = [0.5, 0.5]\n")
    store = tmp_path / "store"
    assert cli.main([command, str(path), "--store", str(store)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err[0] == "ditherlab: invalid sweep spec:"
    assert err[1].startswith("  - accuracy.integrator: unknown integrator 'euler'")
    assert err[2] == "  - time.t_end: must be a valid number, got '100'"
    assert not store.exists()
