"""Result files and figures: CSV and JSON streams, the resume checkpoint, plots.
"""

from contin.util.lazy import lazy_exports

#: module -> the public names it defines, imported on first use (PEP 562): importing the package stays cheap.
#: ``model_figures`` is left out: the function shares its module's name, which the package attribute holds
_FACE = {
    "results": "CsvStream format_value read_csv strict_json truncate_to_valid_rows write_json_atomic",
    "checkpoint": "CheckpointError keep_records read_records rebuild_branches resumable_prefix special_record",
    "dense": "as_number checkpoint_solutions dense_branch kept_indices value_between",
    "expansion": "ENGINE_UNKNOWNS StoredExpansion stores_kept",
    "exports": "EXPORT_FORMATS collect_run stability_code write_exports",
    "figures": "FIGURE_FORMATS figure_style legend_below new_figure save_figure style_names",
    "labels": "axis_label math mathtext_error model_symbols quantity symbol",
    "plotting": "CHANGES SPECIAL bifurcation_diagram branch_label draw_bifurcation_diagram draw_curves",
    "panels": "draw_panels panel_diagram panel_figure_size",
    "panel_options": "PanelError ZoomWindow",
    "plane_plot": "two_parameter_diagram",
    "state_store": "INLINE",
    "state_writer": "StateWriter",
    "sweep_plot": "sweep_map",
}
__all__, __getattr__, __dir__ = lazy_exports(__name__, _FACE)
