"""The analyses a scene can run, one module per ``analysis.type``.

Each module holds one subclass of :class:`contin.analyses.base.Analysis`,
listed by one line of the table :data:`contin.scene.registry.ANALYSES`, which
imports it by name when a scene first asks for it
(docs/howto/new-analysis.md adds one end to end).
"""

from contin.util.lazy import lazy_exports

#: module -> the public names it defines, imported on first use (PEP 562)
_FACE = {
    "base": "Analysis RunContext RunError ScaleCheck",
    "frequency_response": "FrequencyResponse FrequencyResponsePlan StartSetup build_problem engine_problem",
    "branch_recorder": "BranchRecorder row_measures",
}
__all__, __getattr__, __dir__ = lazy_exports(__name__, _FACE)
