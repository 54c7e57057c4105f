"""One home for the facts the harness shares: strategies, epsilons, weights, seeds, alphas (the
store's record keys are :mod:`benchmarks.store`'s). It imports only the tracer's strategy
tuple, so any layer may use it."""
from __future__ import annotations

#: Our sampling strategies in table order (the tracer owns them); ``light`` is biased on purpose.
from reference_tracer.strategies import STRATEGIES  # noqa: F401

#: The strategies that must be unbiased: every one but ``light``.
UNBIASED_STRATEGIES = tuple(s for s in STRATEGIES if s != "light")

#: The strategy every noise ratio of the headline is relative to.
BASELINE = "light"
#: Our strategy whose bias test is the headline's verdict "ours vs Mitsuba" (Mitsuba's ``path`` is MIS).
VERDICT_STRATEGY = "mis"

#: The name under which Mitsuba's renders are recorded: its ``path`` integrator (NEE + MIS).
MITSUBA_STRATEGY = "path"

#: Mitsuba's curves of a scene rendered with its ``direct`` integrator (Veach's comparison):
#: each name maps to our strategy whose sample counts it takes (``reference_tracer.Direct.counts``):
#: BSDF samples only, emitter samples only, and both with MIS.
MITSUBA_DIRECT = {"direct_bsdf": "cosine", "direct_light": "light", "direct_mis": "mis"}

#: relMSE's epsilon: ``mean(d^2 / (ref^2 + RELMSE_EPS))`` (docs/conventions.md).
RELMSE_EPS = 0.01

#: Rec. 709 / sRGB luminance weights of linear R, G, B.
LUMINANCE_WEIGHTS = (0.2126, 0.7152, 0.0722)

#: The seed project's scene, its image size and budget (the "seed comparison" of the report).
SEED_SCENE = "cornell_box"
SEED_SIZE = 400
SEED_SPP = 50
#: fewest rendered budgets a convergence slope is fitted to (two or three points fit any line).
MIN_SLOPE_BUDGETS = 4
#: light sampling's budget in the seed figure, beside uniform at SEED_SPP: about as noisy.
SEED_LIGHT_SPP = 4

#: The regression gate's false-alarm rate for a whole run (all its comparisons together).
GATE_ALPHA = 0.01

#: The false-alarm rate of one bias test in a sweep's summary (one per curve).
BIAS_TEST_ALPHA = 0.001

#: The name of an analytic (closed-form) reference, and the nominal spp recorded for it.
CLOSED_FORM = "closed form"
CLOSED_FORM_SPP = 2**31 - 1
