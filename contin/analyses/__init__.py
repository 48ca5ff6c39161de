"""The analyses a scene can run, one module per ``analysis.type``.

Each module registers its run, its ``analysis`` section schema and its checks
with :func:`contin.scene.registry.register_analysis`; the registry imports the
modules listed in :data:`contin.scene.registry.ANALYSIS_MODULES` by name.
"""
