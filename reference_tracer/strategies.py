"""The sampling strategies the tracer offers at non-specular bounces.

Kept in a module of its own, free of the C++ core, so every layer (the harness's
constants, the store, the report) can name the strategies without loading the core.
"""

#: In the order tables and plots list them. ``light`` is biased on purpose: it sees only
#: light that arrives straight from an emitter.
STRATEGIES = ("uniform", "cosine", "light", "mixture", "mis")
