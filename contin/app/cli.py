"""The ``contin`` command: ``run``, ``sweep``, ``check``, ``models``, ``examples``, ``absorber``, ``budget`` and
``plot``.

Exit status: 0 when the run did everything the scene asked, 1 when it fell
short or failed for numerical reasons (a branch that ended ``start_failed``,
``newton_failed``, ``step_too_small``, ...; the reasons are printed and
recorded in ``summary.json``; for ``sweep``: when at least one grid point fell
short or failed; the sweep still runs every other point and lists them in
``sweep.csv``) or when a result file could not be written (a full disk: the
file and the command that resumes the run are named), 2 on bad input (an
output directory that is not contin's, or that another run is writing,
included), 130 when interrupted (Ctrl-C, SIGTERM, SIGHUP), 141, quietly, when the
reader of its output went away (``contin models | head``).

Each command imports its machinery when it runs (the imports marked
``deferred``), so that ``contin --help`` and ``contin models`` answer without
loading numba and the compiled kernels, and ``--help`` without numpy.
"""

from __future__ import annotations

import argparse
import sys
import textwrap

from contin.util.blas import limit_blas_threads
from contin.util.workers import threads
from contin.util.version import __version__
from contin.util.warning import ContinWarning

__all__ = ["main"]

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130
#: stdout's reader went away (``contin models | head``): the status of a command ended by SIGPIPE, 128 + 13
EXIT_PIPE_CLOSED = 141


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="contin", description="Continuation of periodic vibrations of nonlinear "
                                "mechanical systems: branches, stability, folds and bifurcations.",
                                epilog="Examples ship with contin: `contin examples` lists them, `contin run duffing "
                                "-o results/duffing` runs one by its name, `contin examples --copy DIR` copies "
                                "them to edit. `contin COMMAND --help` describes each command.")
    p.add_argument("--version", action="version", version=f"contin {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run a scene and write result files and plots",
                       formatter_class=argparse.RawDescriptionHelpFormatter,
                       description="Run SCENE and write its result files (branches.csv, special_points.csv, "
                       "summary.json, ...) and plots in OUTDIR, as it goes: an interrupted run is taken up "
                       "with --resume.",
                       epilog=textwrap.dedent("""\
                           examples:
                             contin run duffing -o results/duffing      (an example, by its name)
                             contin run my_scene.yaml -o results/h15 --set analysis.harmonics=15
                             contin run my_scene.yaml -o results/h15 --resume

                           exit status:
                             0    every branch ended as the scene asked
                             1    a branch fell short or failed (the reasons and the uncovered intervals
                                  are printed and stored in summary.json), or a file could not be written
                             2    bad input (scene, --set value, output directory), before anything is written
                             130  interrupted (Ctrl-C, SIGTERM, SIGHUP); --resume goes on
                             141  the reader of the output went away (contin run ... | head), quietly"""))
    r.add_argument("scene", help="scene file (YAML), or the name of an example that ships with contin "
                   "(`contin examples` lists them)")
    r.add_argument("-o", "--outdir", default=None, help="output directory (default: results/<scene name>)")
    r.add_argument("--force", action="store_true",
                   help="write into an output directory that holds files and is not contin's (files of the names "
                   "contin writes are replaced)")
    r.add_argument("--set", dest="overrides", action="append", default=[], metavar="dotted.key=value",
                   help="override a scene value; the value is parsed as YAML (repeatable)")
    r.add_argument("-q", "--quiet", action="store_true", help="no progress display")
    r.add_argument("--resume", action="store_true",
                   help="continue an interrupted run in OUTDIR from its last stored point")
    r.add_argument("--budget", type=float, default=None, metavar="ERR",
                   help="convergence scenes: recommend the cheapest setting whose errors are all <= ERR "
                   "(the same as --set analysis.budget=ERR)")
    sw = sub.add_parser("sweep", help="run a scene at every point of a grid of values, on Dask",
                        description="Run SCENE once per point of the outer product of the --grid axes, each "
                        "point in OUTDIR/points/<name>, indexed in OUTDIR/sweep.csv. Points already complete "
                        "in OUTDIR (same scene) are not run again, so the same command resumes an interrupted "
                        "sweep. The points run on Dask (pip install \"contin[sweep]\"), or with --serial one "
                        "after another in this process without it. Exit status 0 when every point is "
                        "complete, 1 when some failed or fell short (recorded with their messages; a rerun runs "
                        "them again), 2 on bad input, "
                        "130 when interrupted.")
    sw.add_argument("scene", help="scene file (YAML)")
    sw.add_argument("--grid", action="append", required=True, metavar="dotted.key=SPEC",
                    help="a grid axis: a list v1,v2,... or a range start:stop:count (inclusive); "
                    "several --grid give the outer product")
    sw.add_argument("-o", "--outdir", default=None, help="sweep directory (default: results/<scene name>-sweep)")
    sw.add_argument("--force", action="store_true",
                    help="write into a sweep directory that holds files and is not contin's")
    sw.add_argument("--set", dest="overrides", action="append", default=[], metavar="dotted.key=value",
                    help="override a scene value at every point (repeatable)")
    sw.add_argument("--scheduler", default=None, metavar="ADDRESS",
                    help="run on an existing Dask cluster (tcp://HOST:PORT of its scheduler) instead of an "
                    "embedded local cluster")
    sw.add_argument("--workers", type=int, default=None, metavar="N",
                    help="worker processes of the embedded local cluster (default: one per core)")
    sw.add_argument("--serial", action="store_true", help="run the points one after another in this process")
    sw.add_argument("--retries", type=int, default=2, metavar="N",
                    help="times a task that raised an unexpected error is run again (default 2)")
    sw.add_argument("--no-map", dest="map_plot", action="store_false", help="do not draw sweep_map.png")
    sw.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    c = sub.add_parser("check", help="validate a scene and print what would run")
    c.add_argument("scene", help="scene file (YAML), or the name of an example that ships with contin")
    c.add_argument("--set", dest="overrides", action="append", default=[], metavar="dotted.key=value")
    sub.add_parser("models", help="list the built-in models with their parameters, defaults and effects")
    ex = sub.add_parser("examples", help="list the example scenes that ship with contin, or copy them",
                        description="List the example scenes that ship with contin, one line each. `contin run "
                        "NAME -o OUTDIR` runs one by its name; --copy DIR copies every scene and the data files "
                        "they read into DIR, to edit and run from there.")
    ex.add_argument("--copy", metavar="DIR", default=None, help="copy the scenes and their data files into DIR")
    ex.add_argument("--force", action="store_true", help="with --copy: replace files of the same names in DIR")
    ab = sub.add_parser("absorber", help="Den Hartog's optimal damped vibration absorber for a main system m1, k1",
                        description="Optimal tuning and damping of a dynamic vibration absorber (fixed-point theory): "
                        "k2, c with both damping ratios, the fixed points P and Q, the true peak of the optimal "
                        "response, and the undamped absorber's anti-resonance and resonances. Any consistent units.")
    ab.add_argument("--m1", type=float, required=True, help="main mass")
    ab.add_argument("--k1", type=float, required=True, help="main spring stiffness")
    size = ab.add_mutually_exclusive_group(required=True)
    size.add_argument("--m2", type=float, help="absorber mass")
    size.add_argument("--max-amplification", type=float, metavar="A",
                      help="instead of --m2: the largest allowed |X1|/delta_st (> 1)")
    ab.add_argument("--sizing", choices=("fixed_points", "peak"), default="fixed_points",
                    help="with --max-amplification: put the fixed points (seed rule) or the true peak at A")
    ab.add_argument("--plot", metavar="FILE", default=None, help="save |X1|/delta_st against w (PNG, PDF, SVG)")
    ab.add_argument("--json", metavar="FILE", default=None, help="also write the design as JSON")
    bu = sub.add_parser("budget", help="recommend a setting from a finished convergence run",
                        description="Read OUTDIR/convergence.csv of a convergence run, print the cheapest "
                        "setting whose errors are all <= ERR (the reference excluded) or say that none is, "
                        "and redraw OUTDIR/convergence.png with ERR as a line.")
    bu.add_argument("outdir", help="a result directory of `contin run` on a convergence scene")
    bu.add_argument("error", type=float, metavar="ERR", help="largest error accepted")
    pl = sub.add_parser("plot", help="time history, orbit and spectrum of a stored point")
    pl.add_argument("outdir", help="a result directory of `contin run`")
    pl.add_argument("--point", type=int, required=True, metavar="ROW", help="row of branches.csv (0-based)")
    return p


def _fail(message: str, code: int = EXIT_BAD_INPUT) -> int:
    # paths stay whole: never broken at a hyphen or inside a long word
    lines = textwrap.wrap(message, 100, break_long_words=False, break_on_hyphens=False)
    sys.stderr.write("contin: error: " + "\n".join(lines) + "\n")
    return code


def cmd_models() -> int:
    from contin.model.catalog import MODELS, load_builtin_models  # deferred: numpy, the models (0.13 s)

    load_builtin_models()
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


def cmd_examples(args) -> int:
    from pathlib import Path

    from contin.app.examples import copy_examples, listing  # deferred: numpy (0.1 s), not for --help

    if args.copy is None:
        if args.force:
            return _fail("--force goes with --copy DIR")
        print("\n".join(listing()))
        return EXIT_OK
    written = copy_examples(args.copy, force=args.force)
    print(f"{len(written)} files copied to {args.copy}; run one with: contin run "
          f"{Path(args.copy) / 'duffing.yaml'} -o results/duffing")
    return EXIT_OK


def cmd_check(args) -> int:
    from contin.app.examples import find_scene  # deferred: numpy (0.1 s), not for --help
    from contin.scene.build import build_model  # deferred: numba kernels, matplotlib (1 s), per command
    from contin.scene.parse import load_scene  # deferred: as scene.build
    from contin.scene.registry import analysis, check_scene  # deferred: as scene.build

    # the same steps as `contin run` before it writes anything, so that check refuses what run would
    scene = load_scene(find_scene(args.scene), args.overrides)
    model = build_model(scene)
    plan = check_scene(scene, model)
    a = scene.analysis
    print(f"scene: {scene.source}")
    print(model.describe())
    print("parameters: " + ", ".join(f"{k}={v:g}" for k, v in model.parameters.items()))
    print(f"analysis: {a['type']}")
    for line in analysis(a["type"]).describe(plan, scene, model):
        print(line)
    return EXIT_OK


def _resume_command(args, outdir) -> str:
    """The command that resumes this run: ``contin run SCENE -o OUTDIR --resume`` with its --set and --budget."""
    import shlex

    cmd = ["contin", "run", args.scene, "-o", str(outdir), "--resume"]
    for o in args.overrides:
        cmd += ["--set", o]
    if args.budget is not None:
        cmd += ["--budget", repr(args.budget)]
    return shlex.join(cmd)


def _interrupted(args, outdir) -> int:
    """Say how to resume an interrupted run on stderr (the runner put it in summary.json); exit status 130."""
    command = _resume_command(args, outdir)
    sys.stderr.write(f"contin: the run was interrupted; the results so far are in {outdir}. To resume it from "
                     f"the last stored point:\n  {command}\n")
    return EXIT_INTERRUPTED


def _branch_line(b: dict) -> str:
    if b["status"] == "interrupted":  # the continuation stopped at the interrupt: say where, not how
        at = str(b.get("message", "")).partition(" at ")[2]
        return f"branch {b['branch']} (nu={b['nu']}): {b['points']} points, interrupted" + (f" at {at}" if at else "")
    status = b["status"]
    if b.get("handed_over_to") is not None:  # the end of one method, not of the branch: say who goes on
        status += f", continued by shooting as branch {b['handed_over_to']}"
    if b.get("recut_to") is not None:  # a crawl, continued with the orbits cut at another section
        status += f", continued at another section of its orbits as branch {b['recut_to']}"
    return f"branch {b['branch']} (nu={b['nu']}): {b['points']} points, {status}: {b['message']}"


def cmd_run(args) -> int:
    from pathlib import Path

    from contin.app.examples import find_scene  # deferred: numpy (0.1 s), not for --help
    from contin.app.runner import WriteFailed, run_scene  # deferred: numba kernels, matplotlib (1 s), per command
    from contin.scene.parse import SceneError, load_scene  # deferred: as the runner

    scene_file = find_scene(args.scene)  # a file, or the name of a shipped example
    overrides = list(args.overrides)
    if args.budget is not None:
        import math

        if not (math.isfinite(args.budget) and args.budget > 0):
            raise SceneError("--budget", "a positive finite number (the largest error accepted)", args.budget)
        kind = load_scene(scene_file, overrides).analysis["type"]
        if kind != "convergence":
            raise SceneError("--budget", "a convergence scene (analysis.type: convergence)", kind)
        overrides.append(f"analysis.budget={args.budget!r}")
    if args.outdir == "":
        raise SceneError("-o", "a directory name for the results", "")
    scene = load_scene(scene_file, overrides)
    outdir = Path(args.outdir) if args.outdir is not None else Path("results") / Path(args.scene).stem
    if outdir.exists() and not outdir.is_dir():
        raise SceneError("-o", "a directory for the results (new or existing)", str(outdir),
                         hint=" (a file of that name exists)")
    command = _resume_command(args, outdir)
    try:
        summary = run_scene(scene, outdir, progress=not args.quiet, resume=args.resume, force=args.force,
                            resume_command=command)
    except KeyboardInterrupt:  # a second Ctrl-C, or one outside the analysis
        if not (outdir / "summary.json").is_file():
            return _fail("interrupted", EXIT_INTERRUPTED)
        return _interrupted(args, outdir)
    except WriteFailed as exc:  # the results so far stay, and the run resumes once the file can be written
        return _fail(f"{exc}. The results so far are in {outdir}; once the file can be written (space freed, "
                     f"permission given), resume the run from its last stored point with: {command}", EXIT_FAILED)
    a = summary.get("analysis", {})
    for line in a.get("table", []) if scene.analysis["type"] == "convergence" else []:
        print(line)
    for b in a.get("branches", []):
        print(_branch_line(b))
    for c in a.get("curves", []):
        ends = "; ".join(f"{e['side']} {e['status']}" for e in c["ends"])
        found = ", ".join(f"{n} {k}" for k, n in c["special_points"].items() if n)
        print(f"curve {c['curve']} ({c['kind']}, nu={c['nu']}): {c['points']} points, {ends}"
              + (f"; {found}" if found else ""))
    print(f"results in {outdir} ({summary['timings']['total']:.2f} s)")
    if summary["status"] == "interrupted":
        return _interrupted(args, outdir)
    if summary["status"] == "incomplete":
        lines = summary.get("shortfalls") or []
        sys.stderr.write("contin: the run fell short of what the scene asked:\n"
                         + "".join(f"  {line}\n" for line in lines))
        return EXIT_FAILED
    return EXIT_OK


def cmd_budget(args) -> int:
    import json
    import math
    from pathlib import Path

    from contin.analyses.convergence import replot  # deferred: numba kernels, matplotlib (1.2 s), per command
    from contin.analyses.convergence_errors import read_records, recommend  # deferred: as convergence
    from contin.scene.files import SUMMARY_CAP, read_input  # deferred: as convergence
    from contin.scene.schema import SceneError  # deferred: numpy (0.1 s), not for --help

    if not (math.isfinite(args.error) and args.error > 0):
        raise SceneError("ERR", "a positive finite number (the largest error accepted)", args.error)
    out = Path(args.outdir)
    try:
        raw, _ = read_input(out / "summary.json", SUMMARY_CAP)  # a regular file, not a pipe or a device
        summary = json.loads(raw.decode("utf-8"))
        a = summary["analysis"]
        columns, cost = a["columns"], a.get("cost", "wall_time")
    except (OSError, ValueError, KeyError, TypeError):
        raise SceneError(str(out), "the result directory of a finished convergence run (summary.json with "
                         "its analysis)", None) from None
    rec = recommend(read_records(out / "convergence.csv", columns), columns, args.error, cost)
    print(rec["message"])
    if summary.get("scene", {}).get("output", {}).get("plots", True):
        print(f"plot: {replot(out, args.error)}")
    return EXIT_OK


def cmd_absorber(args) -> int:
    import math

    from contin.modal.absorber_design import design_absorber, plot_design  # deferred: scipy (0.1 s), per command
    from contin.scene.schema import SceneError  # deferred: numpy (0.1 s), not for --help

    for flag, v in (("--m1", args.m1), ("--k1", args.k1), ("--m2", args.m2),
                    ("--max-amplification", args.max_amplification)):
        if v is not None and not (math.isfinite(v) and v > 0):
            raise SceneError(flag, "a positive finite number", v)
    if args.max_amplification is not None and args.max_amplification <= 1:
        raise SceneError("--max-amplification", "a number above 1 (the static response |X1|/delta_st = 1)",
                         args.max_amplification)
    if args.m2 is not None and args.sizing != "fixed_points":
        raise SceneError("--sizing", "to be used with --max-amplification (with --m2 the mass is given)", args.sizing)
    try:  # values whose ratios the design cannot hold (m2/m1 out of range, an overflow): the message names them
        d = design_absorber(args.m1, args.k1, args.m2, max_amplification=args.max_amplification, sizing=args.sizing)
    except ValueError as exc:
        raise SceneError("absorber", "values whose ratios the design can hold", None, hint=f": {exc}") from None
    print(d.report())
    if args.plot:
        plot_design(d, args.plot)
        print(f"plot: {args.plot}")
    if args.json:
        import json

        from contin.output.results import strict_json  # deferred: numpy (0.1 s), not for --help
        from contin.util.safe_files import write_user_file  # deferred: as output.results

        # a regular file is replaced atomically; a device or pipe (/dev/stdout, a FIFO) is written in place
        text = json.dumps(strict_json(d.as_dict()), indent=2, allow_nan=False)
        write_user_file(args.json, lambda fh: fh.write(text + "\n"))
        print(f"json: {args.json}")
    return EXIT_OK


def cmd_sweep(args) -> int:
    import signal
    from pathlib import Path

    from contin.app.sweep import SweepOptions, run_sweep, sweep_command  # deferred: the scene machinery (1 s)
    from contin.app.sweep_grid import parse_grid  # deferred: as app.sweep

    outdir = args.outdir if args.outdir is not None else str(Path("results") / (Path(args.scene).stem + "-sweep"))
    opts = SweepOptions(scene=args.scene, grid=tuple(parse_grid(g) for g in args.grid), outdir=outdir,
                        overrides=tuple(args.overrides), scheduler=args.scheduler, workers=args.workers,
                        serial=args.serial, retries=args.retries, map_plot=args.map_plot, progress=not args.quiet,
                        force=args.force)

    def stop(signum, frame):  # SIGTERM and SIGHUP end a sweep as Ctrl-C does
        raise KeyboardInterrupt

    stops = [getattr(signal, n) for n in ("SIGTERM", "SIGHUP") if hasattr(signal, n)]
    previous = {s: signal.signal(s, stop) for s in stops if signal.getsignal(s) is not signal.SIG_IGN}  # nohup
    try:
        result = run_sweep(opts)
    except KeyboardInterrupt:
        if not (Path(opts.outdir) / "sweep.csv").is_file():
            return _fail("interrupted", EXIT_INTERRUPTED)
        sys.stderr.write(f"contin: the sweep was interrupted; the points finished so far are in {opts.outdir} "
                         "(sweep.csv). To resume it (the complete points are not run again):\n"
                         f"  {sweep_command(opts)}\n")
        return EXIT_INTERRUPTED
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
    c = result.counts
    print(f"sweep: {len(result.records)} points, {c.get('complete', 0)} complete ({c.get('reused', 0)} from "
          f"before), {len(result.failed)} failed or incomplete; index in {Path(opts.outdir) / 'sweep.csv'} "
          f"({result.seconds:.1f} s)")
    for r in result.failed:
        msg = " ".join(str(r.get("message", "")).split())
        print(f"  {r['status']} {r['point']}: {msg}")
    return EXIT_FAILED if result.failed else EXIT_OK


def _one_line_warnings():
    """Show each warning as one line ``contin: warning: ...`` on stderr, each text once; returns the undo.

    Python's own display adds the category, file and source line of the
    ``warnings.warn`` call, which tell a user nothing. A caller that records or
    shows warnings its own way (``warnings.catch_warnings(record=True)``, a
    replaced ``warnings.showwarning``) keeps its way: nothing is installed.
    """
    import warnings

    impl = getattr(warnings, "_showwarnmsg_impl", None)
    if warnings.showwarning is not getattr(warnings, "_showwarning_orig", None) or \
            getattr(impl, "__module__", None) != "warnings":
        return lambda: None
    previous, seen = warnings.showwarning, set()

    def show(message, category, filename, lineno, file=None, line=None):
        text = " ".join(str(message).split())
        text = text[len("contin: "):] if text.startswith("contin: ") else text
        if not issubclass(category, ContinWarning):  # another library's: its category says whose
            text = f"{category.__name__}: {text}"
        if text in seen:
            return
        seen.add(text)
        try:
            stream = file or sys.stderr
            stream.write(f"contin: warning: {text}\n")
            stream.flush()
        except (OSError, ValueError):  # a closed stderr: the warning cannot be shown, the run goes on
            pass

    warnings.showwarning = show

    def restore():
        if warnings.showwarning is show:
            warnings.showwarning = previous

    return restore


def _pipe_closed() -> int:
    """The reader of stdout went away (``contin models | head``): no message, no error at exit."""
    import os

    try:  # what is still buffered goes nowhere, instead of failing again when Python exits
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):
        pass
    return EXIT_PIPE_CLOSED


def main(argv=None) -> int:
    """The ``contin`` command; returns its exit status (see the module's docstring)."""
    restore = _one_line_warnings()
    try:
        code = _main(argv)
        sys.stdout.flush()  # a closed pipe is met here, not when Python exits
        return code
    except BrokenPipeError:
        return _pipe_closed()
    finally:
        restore()


def _main(argv=None) -> int:
    args = _parser().parse_args(argv)  # --help and --version exit here
    from contin.analyses.base import RunError  # deferred: with SceneError
    from contin.scene.schema import SceneError  # deferred: numpy (0.1 s), not for --help

    try:  # the environment's thread counts, before anything runs
        limit_blas_threads()
        threads()
    except ValueError as exc:
        return _fail(str(exc))
    try:
        if args.command == "models":
            return cmd_models()
        if args.command == "examples":
            return cmd_examples(args)
        if args.command == "check":
            return cmd_check(args)
        if args.command == "absorber":
            return cmd_absorber(args)
        if args.command == "budget":
            return cmd_budget(args)
        if args.command == "plot":
            from contin.app.pointplot import plot_point  # deferred: numba kernels, matplotlib (1.3 s), per command

            print(plot_point(args.outdir, args.point))
            return EXIT_OK
        if args.command == "sweep":
            return cmd_sweep(args)
        return cmd_run(args)
    except SceneError as exc:
        return _fail(str(exc))
    except RunError as exc:
        return _fail(str(exc), EXIT_FAILED)
    except KeyboardInterrupt:
        return _fail("interrupted", EXIT_INTERRUPTED)
    except BrokenPipeError:  # stdout's reader went away: main() ends quietly
        raise
    except OSError as exc:  # a place that cannot be written or read: a message, not a traceback
        import errno

        where = f"{exc.filename}: " if exc.filename else ""
        # a disk that is full or fails is no bad input: the same command works once there is room
        code = EXIT_FAILED if exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EIO, errno.EFBIG) else EXIT_BAD_INPUT
        return _fail(f"{where}{exc.strerror or exc}", code)


if __name__ == "__main__":
    sys.exit(main())
