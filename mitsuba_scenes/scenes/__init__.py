"""The scene suite: one module per scene, each exposing ``build(**params) -> rt.Scene``."""
