"""Per-point status codes, shared with the result cube's ``status`` variable."""
OK = 0            # finished, all observables finite
NOT_COMPUTED = 1  # cube placeholder: the point has not been run yet
FAILED = 2        # the integrator gave up (max steps, step-size underflow)
NON_FINITE = 3    # the state or an observable became NaN / inf

MEANINGS = {
    OK: "ok",
    NOT_COMPUTED: "not_yet_computed",
    FAILED: "failed",
    NON_FINITE: "non_finite",
}
