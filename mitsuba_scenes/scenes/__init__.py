"""The scene suite: one module per scene, each exposing ``build(**params) -> rt.Scene``.

:data:`SUITE` names them in suite order; :mod:`mitsuba_scenes.suite` builds them by name,
and :mod:`mitsuba_scenes.scene_files` keeps a user's file from taking one of these names.
"""

#: Scene names in suite order; each is a module of this package.
SUITE = ("cornell_box", "cornell_glass", "cornell_mirror", "cornell_mesh", "small_light",
         "large_light", "glossy_plates", "furnace")
