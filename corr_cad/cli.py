"""Command line: ``corr-cad run SCENE``, ``corr-cad new SCENE``, ``corr-cad schema``.

Exit codes: 0 success, 2 bad input or a refused design (one line on stderr,
no traceback, nothing written).
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path

from . import __version__
from .errors import CorrCadError

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="corr-cad",
        description=(
            "Profiles, machining files and mesh forces for compound oscillatory roller "
            "reducers. Units: mm, N, N*mm, MPa."
        ),
    )
    p.add_argument("--version", action="version", version=f"corr-cad {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    run = sub.add_parser("run", help="build what a scene file asks for")
    run.add_argument("scene", type=Path, help="scene file (TOML)")
    run.add_argument(
        "--out", type=Path, default=None, help="output folder (default outputs/<scene name>)"
    )
    run.add_argument("--quiet", action="store_true", help="print nothing but errors")
    run.add_argument(
        "--executor",
        choices=("process", "serial", "dask"),
        default="process",
        help="where Monte Carlo and allocation samples run (default: a process pool)",
    )
    run.add_argument(
        "--scheduler", default=None, help="Dask scheduler address (with --executor dask)"
    )
    run.add_argument(
        "--workers", type=int, default=None, help="process pool size (default: all cores)"
    )
    bench = sub.add_parser("bench", help="measure what accuracy costs in time (tables, CSV, PNG)")
    bench.add_argument(
        "--out", type=Path, default=Path("outputs") / "bench", help="default outputs/bench"
    )
    bench.add_argument(
        "--study",
        action="append",
        choices=("profile", "solids", "solver", "speed", "montecarlo", "throughput"),
        help="run only this study (repeatable); default all",
    )
    bench.add_argument("--quick", action="store_true", help="fewer settings and repeats")
    schema = sub.add_parser(
        "schema", help="print the JSON Schema of scene files (for TOML editors)"
    )
    schema.add_argument(
        "--out", type=Path, default=None, help="write it to this file instead of printing"
    )
    new = sub.add_parser("new", help="write a commented scene template")
    new.add_argument("scene", type=Path, help="file to create (refuses to overwrite)")
    return p


def _run(args: argparse.Namespace) -> int:
    from .outputs import StagingDir
    from .pipeline import run_scene
    from .scene import load_scene

    scene = load_scene(args.scene)
    out = args.out if args.out is not None else Path("outputs") / scene.name
    say = (lambda m: None) if args.quiet else (lambda m: print(m, flush=True))
    say(f"corr-cad {__version__}: scene {scene.name!r} -> {out}")
    with _executor(args, scene) as executor, StagingDir(out) as stage:
        manifest = run_scene(scene, stage, progress=say, executor=executor)
    if not args.quiet:
        acc = manifest.get("accuracy", {}).get("working_profile")
        if acc:
            print(
                f"working profile: {acc['representation']}, tolerance {acc['tolerance_mm']:g} mm, "
                f"measured max deviation {acc['max_deviation_mm']:.3g} mm"
            )
        f = manifest.get("forces")
        if f:
            print(
                f"roller 1: F_j mean {f['F_j_mean']:.1f} N, F_n peak {f['F_n_peak']:.1f} N, "
                f"p_max {f['p_max']:.0f} MPa, loaded rollers {f['loaded_rollers_min']}-"
                f"{f['loaded_rollers_max']}"
            )
        i = manifest.get("interference")
        if i:
            state = "none beyond tessellation" if i["ok"] else f"{i['violations']} violations"
            print(f"interference over {i['positions']} crank positions: {state}")
        print(f"wrote {len(manifest['files']) + 1} files to {out}")
    failed = [k for k, r in manifest.get("checks", {}).items() if not r["passed"]]
    if failed:
        print(f"corr-cad: check failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


@contextlib.contextmanager
def _executor(args: argparse.Namespace, scene):
    """The executor for sample work; only started when the scene needs one."""
    from .errors import SceneError

    needs = {"montecarlo", "allocation", "sweeps"} & set(scene.formats)
    if args.executor == "dask":
        if not args.scheduler:
            raise SceneError("--executor dask needs --scheduler ADDRESS (e.g. tcp://host:8786)")
        try:
            from dask.distributed import Client
        except ImportError as exc:
            raise SceneError(
                "--executor dask needs the 'dask' extra: pip install -e '.[dask]'"
            ) from exc
        client = Client(args.scheduler)
        try:
            yield client
        finally:
            client.close()
        return
    if args.executor == "serial" or not needs:
        yield None
        return
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        yield pool


def _new(args: argparse.Namespace) -> int:
    from .errors import SceneError
    from .scene import template_text

    path: Path = args.scene
    if path.exists():
        raise SceneError(f"{path} exists; choose another name")
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".part")
    tmp.write_text(template_text(), encoding="utf-8")
    tmp.replace(path)
    print(f"wrote {path}")
    return 0


def _schema(args: argparse.Namespace) -> int:
    from .schema_json import schema_text

    text = schema_text()
    if args.out is None:
        sys.stdout.write(text)
        return 0
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_name(args.out.name + ".part")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(args.out)
    print(f"wrote {args.out}")
    return 0


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        if args.command == "run":
            return _run(args)
        if args.command == "bench":
            from .bench import STUDIES, run

            run(args.out, args.study or list(STUDIES), quick=args.quick)
            print(f"wrote the benchmark tables and plots to {args.out}")
            return 0
        if args.command == "schema":
            return _schema(args)
        return _new(args)
    except CorrCadError as exc:
        print(f"corr-cad: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("corr-cad: interrupted; previous outputs left as they were", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
