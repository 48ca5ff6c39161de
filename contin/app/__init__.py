"""The application: the command line, the runner of one scene, parameter sweeps, progress.
"""
