"""The CLI pins BLAS to one thread for identification's subcommands, before numpy loads."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from campaign.cli.main import BLAS_THREAD_VARIABLES, ONE_BLAS_THREAD

REPO = Path(__file__).resolve().parents[2]

#: runs ``campaign <command> --help`` in a fresh interpreter and prints the BLAS variables
#: numpy was imported with (the subcommand's module imports the stage, and so numpy)
PROBE = """
import json, os, sys
from campaign.cli.main import main
try:
    main([sys.argv[1], "--help"])
except SystemExit:
    pass
print(json.dumps({"numpy": "numpy" in sys.modules,
                  "env": {k: os.environ.get(k) for k in VARIABLES}}))
""".replace("VARIABLES", repr(BLAS_THREAD_VARIABLES))


def _probe(command: str, **env: str) -> dict:
    clean = {k: v for k, v in os.environ.items() if k not in BLAS_THREAD_VARIABLES}
    clean["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO), clean.get("PYTHONPATH")]))
    out = subprocess.run([sys.executable, "-c", PROBE, command], capture_output=True, text=True, check=True,
                         env={**clean, **env}, cwd=REPO)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("command", sorted(ONE_BLAS_THREAD))
def test_identification_commands_load_numpy_with_one_blas_thread(command):
    got = _probe(command)
    assert got["numpy"], "the probe must import numpy through the subcommand"
    assert got["env"] == dict.fromkeys(BLAS_THREAD_VARIABLES, "1")


def test_a_thread_count_the_user_set_is_kept():
    got = _probe("identify", OPENBLAS_NUM_THREADS="3")
    assert got["env"]["OPENBLAS_NUM_THREADS"] == "3"
    assert got["env"]["OMP_NUM_THREADS"] == "1"


def test_other_commands_leave_the_blas_threads_alone():
    got = _probe("meff")
    assert got["env"] == dict.fromkeys(BLAS_THREAD_VARIABLES)
