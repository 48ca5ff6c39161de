"""The ``contin`` command: ``run``, ``check``, ``models`` and ``plot``."""

from __future__ import annotations

import argparse
import sys
import textwrap

__all__ = ["main"]

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130


def _parser() -> argparse.ArgumentParser:
    import contin

    p = argparse.ArgumentParser(prog="contin", description="Continuation of periodic vibrations of nonlinear "
                                "mechanical systems: branches, stability, folds and bifurcations.")
    p.add_argument("--version", action="version", version=f"contin {contin.__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run a scene and write result files and plots")
    r.add_argument("scene", help="scene file (YAML)")
    r.add_argument("-o", "--outdir", default=None, help="output directory (default: results/<scene name>)")
    r.add_argument("--set", dest="overrides", action="append", default=[], metavar="dotted.key=value",
                   help="override a scene value; the value is parsed as YAML (repeatable)")
    r.add_argument("-q", "--quiet", action="store_true", help="no progress display")
    r.add_argument("--resume", action="store_true",
                   help="continue an interrupted run in OUTDIR from its last stored point")
    c = sub.add_parser("check", help="validate a scene and print what would run")
    c.add_argument("scene")
    c.add_argument("--set", dest="overrides", action="append", default=[], metavar="dotted.key=value")
    sub.add_parser("models", help="list the built-in models with their parameters, defaults and effects")
    pl = sub.add_parser("plot", help="time history, orbit and spectrum of a stored point")
    pl.add_argument("outdir", help="a result directory of `contin run`")
    pl.add_argument("--point", type=int, required=True, metavar="ROW", help="row of branches.csv (0-based)")
    return p


def _fail(message: str, code: int = EXIT_BAD_INPUT) -> int:
    sys.stderr.write("contin: error: " + "\n".join(textwrap.wrap(message, 100)) + "\n")
    return code


def cmd_models() -> int:
    from contin.catalog import MODELS, _load

    _load()
    for name in sorted(MODELS):
        spec = MODELS[name]
        print(f"{name}: {spec.summary}")
        print("  parameters: " + ", ".join(f"{k}={v:g}" for k, v in spec.parameters.items()))
        print("  effects (default on: " + ", ".join(spec.default_effects) + "):")
        for e, d in spec.effects.items():
            print(f"    {e:18s} {d}")
        if spec.options:
            print("  options: " + ", ".join(f"{k}={v!r}" for k, v in spec.options.items()))
    return EXIT_OK


def cmd_check(args) -> int:
    from contin.runner import build_model
    from contin.scene import load_scene

    scene = load_scene(args.scene, args.overrides)
    model = build_model(scene)
    a = scene.analysis
    print(f"scene: {scene.source}")
    print(model.describe())
    print("parameters: " + ", ".join(f"{k}={v:g}" for k, v in model.parameters.items()))
    print(f"analysis: {a['type']}")
    if a["type"] == "frequency_response":
        from contin.analyses.frequency_response import build_problem

        hb = build_problem(scene, model)
        print(f"  parameter {hb.parameter} over {a['range']}, harmonics H={hb.H}, subharmonic nu={hb.nu}, "
              f"samples N={hb.N}")
        print(f"  unknowns: {hb.size} = {hb.n} dof x (2H+1)")
        print(f"  stability: {a['stability']}; switching at: {', '.join(a['switch']) or 'none'}")
    elif a["type"] == "static":
        print(f"  equilibria (H = 0) in {a['parameter']} over {a['range']}; unknowns: {model.n_dof} dof")
    elif a["type"] == "backbone":
        print(f"  free periodic solutions of mode(s) {a['mode']}, {a['amplitude']} amplitude of "
              f"{a['dof'] or 'the first observable'} over {a['range']} ({a['spacing']} spacing), harmonics "
              f"H={a['harmonics']}; unknowns: {model.n_dof * (2 * a['harmonics'] + 1) + 2} = {model.n_dof} dof x "
              f"(2H+1) + frequency + unfolding parameter")
    return EXIT_OK


def cmd_run(args) -> int:
    from pathlib import Path

    from contin.runner import run_scene
    from contin.scene import load_scene

    scene = load_scene(args.scene, args.overrides)
    outdir = Path(args.outdir) if args.outdir else Path("results") / Path(args.scene).stem
    summary = run_scene(scene, outdir, progress=not args.quiet, resume=args.resume)
    a = summary.get("analysis", {})
    for b in a.get("branches", []):
        print(f"branch {b['branch']} (nu={b['nu']}): {b['points']} points, {b['status']}: {b['message']}")
    print(f"results in {outdir} ({summary['timings']['total']:.2f} s)")
    return EXIT_INTERRUPTED if summary["status"] == "interrupted" else EXIT_OK


def main(argv=None) -> int:
    from contin.runner import RunError
    from contin.scene import SceneError

    args = _parser().parse_args(argv)
    from contin.blas import limit_blas_threads

    limit_blas_threads()
    try:
        if args.command == "models":
            return cmd_models()
        if args.command == "check":
            return cmd_check(args)
        if args.command == "plot":
            from contin.pointplot import plot_point

            print(plot_point(args.outdir, args.point))
            return EXIT_OK
        return cmd_run(args)
    except SceneError as exc:
        return _fail(str(exc))
    except RunError as exc:
        return _fail(str(exc), EXIT_FAILED)
    except KeyboardInterrupt:
        return _fail("interrupted", EXIT_INTERRUPTED)


if __name__ == "__main__":
    sys.exit(main())
