"""Scenes: the YAML format, its schema and checks, the table of analyses, the one sweep plan, and the model
a scene describes.
"""

from contin.util.lazy import lazy_exports

#: module -> the public names it defines, imported on first use (PEP 562)
_FACE = {
    "parse": "Scene load_scene model_frequency parse_scene scene_from_data",
    "schema": "START_SIMULATION Key SceneError",
    "registry": "ANALYSES analysis analysis_names check_output check_scene shortfalls",
    "sweep_plan": "SweepPlan sweep_names sweep_plan",
    "build": "build_model",
}
__all__, __getattr__, __dir__ = lazy_exports(__name__, _FACE)
