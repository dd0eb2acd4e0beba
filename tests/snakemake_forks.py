"""The ``snakemake`` command, run by its own entry point in a copy of one process that has
Snakemake and the workflow's start-up modules loaded.

A Snakemake start-up spends about a second of CPU loading Snakemake, its plugins and the
package's import graph for the stage digests before it reads the configuration; the tests
start the workflow about sixty times, most of them dry runs that cost little more. :func:`run`
sends each command to one server process per test process (started on first use): it forks,
and the child runs ``snakemake.cli.main`` with the command's arguments, working folder and
environment, its stdout and stderr in files of their own, as the console script does in a
process of its own. The child evaluates the Snakefile, checks the configuration, plans and
runs the jobs (each a process of its own, as always) itself; only the imports, the plugin
registries and the import graph (cached by each file's modification time and size) come from
the server. The reduced campaign, the documented re-analysis and the killed run start the
console script itself.
"""

from __future__ import annotations

import atexit
import json
import os
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

_SERVER = Path(__file__).with_name("snakemake_forks.py")
_lock = threading.Lock()
_proc: subprocess.Popen | None = None


def _server() -> subprocess.Popen:
    global _proc
    if _proc is None or _proc.poll() is not None:
        _proc = subprocess.Popen([sys.executable, str(_SERVER)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                 text=True, bufsize=1)
        atexit.register(_stop, _proc)
    return _proc


def stop() -> None:
    """End this process's server, if it runs (the end of the test session)."""
    if _proc is not None and _proc.poll() is None:
        _stop(_proc)


def _stop(proc: subprocess.Popen) -> None:
    """End the server (end of its input) and wait for it, so its CPU time counts as this process's children's."""
    if proc.stdin.closed:
        return
    proc.stdin.close()
    try:
        proc.wait(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def run(args: list[str], *, cwd: Path, env: dict | None = None, timeout: float = 600) -> subprocess.CompletedProcess:
    """``snakemake ARGS`` in ``cwd`` with the environment ``env`` (default: this process's);
    returns its exit status, stdout and stderr."""
    with _lock, tempfile.TemporaryDirectory() as tmp:
        out, err = Path(tmp, "stdout"), Path(tmp, "stderr")
        request = {"args": [str(a) for a in args], "cwd": str(cwd), "env": dict(os.environ if env is None else env),
                   "stdout": str(out), "stderr": str(err), "timeout": int(timeout)}
        proc = _server()
        proc.stdin.write(json.dumps(request) + "\n")
        line = proc.stdout.readline()
        if not line:
            raise RuntimeError(f"the Snakemake server ended (status {proc.wait()})")
        status = json.loads(line)["status"]
        return subprocess.CompletedProcess(["snakemake", *request["args"]], status, out.read_text(errors="replace"),
                                           err.read_text(errors="replace"))


def _child(request: dict) -> None:
    """In the forked child: become ``snakemake ARGS`` and exit with its status."""
    import atexit as _atexit
    import signal
    import traceback

    code = 1
    try:
        signal.alarm(request["timeout"])
        null = os.open(os.devnull, os.O_RDONLY)
        os.dup2(null, 0)
        os.close(null)
        for fd, name in ((1, "stdout"), (2, "stderr")):
            target = os.open(request[name], os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
            os.dup2(target, fd)
            os.close(target)
        os.chdir(request["cwd"])
        os.environ.clear()
        os.environ.update(request["env"])
        sys.argv = [str(Path(sys.executable).with_name("snakemake")), *request["args"]]
        from snakemake.cli import main
        from snakemake.workflow import Workflow

        Workflow._rundir = os.getcwd()      # what Snakemake notes as the run's folder when it loads

        try:
            main()
            code = 0
        except SystemExit as exc:
            code = exc.code
            if code is None:
                code = 0
            elif not isinstance(code, int):
                print(code, file=sys.stderr)
                code = 1
        except BaseException:
            traceback.print_exc()
            code = 1
        _atexit._run_exitfuncs()
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except Exception:
                pass
        os._exit(code)


def _serve() -> None:
    """Load what every start-up loads, then fork a child per request line on stdin."""
    sys.path[0] = str(Path(sys.executable).parent)      # as for the console script, not tests/
    import snakemake.api  # noqa: F401
    import snakemake.cli
    import snakemake.dag  # noqa: F401
    import snakemake.report  # noqa: F401
    import snakemake.workflow  # noqa: F401
    import yaml  # noqa: F401

    # the package the workflow imports: Snakemake puts the Snakefile's folder first on sys.path
    sys.path.insert(0, str(_SERVER.parents[1]))
    from campaign.pipeline import config, digests, paths  # noqa: F401

    # Snakemake's plugin registries (entry points, read once per process)
    for registry in ("ExecutorPluginRegistry", "StoragePluginRegistry", "ReportPluginRegistry",
                     "LoggerPluginRegistry", "SchedulerPluginRegistry"):
        getattr(snakemake.cli, registry)()
    # the package's import graph and sources for the stage digests, cached by each file's
    # modification time (and size)
    for path in digests.modules().values():
        digests._content(path, os.stat(path).st_mtime_ns)
    for line in sys.stdin:
        request = json.loads(line)
        pid = os.fork()
        if pid == 0:
            _child(request)
        _, status = os.waitpid(pid, 0)
        code = os.waitstatus_to_exitcode(status)
        sys.stdout.write(json.dumps({"status": code}) + "\n")
        sys.stdout.flush()


if __name__ == "__main__":
    _serve()
