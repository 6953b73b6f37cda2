"""tests/bytecode_cache.py: with PYTHONDONTWRITEBYTECODE the suite's processes still reuse their
bytecode, kept under the temporary folder, not in the tree."""
import subprocess
import sys
from pathlib import Path

import bytecode_cache

ROOT = Path(__file__).resolve().parents[1]


def test_a_shell_that_forbids_bytecode_in_the_tree_gets_it_under_the_temporary_folder():
    environ = {"PYTHONDONTWRITEBYTECODE": "1", "HOME": "/root"}
    prefix = bytecode_cache.outside_the_tree(environ)
    assert environ == {"PYTHONPYCACHEPREFIX": prefix, "HOME": "/root"}
    assert not Path(prefix).resolve().is_relative_to(ROOT)


def test_a_prefix_the_shell_names_is_kept_and_a_shell_without_the_setting_left_alone():
    environ = {"PYTHONDONTWRITEBYTECODE": "1", "PYTHONPYCACHEPREFIX": "/var/cache/mine"}
    assert bytecode_cache.outside_the_tree(environ) == "/var/cache/mine"
    assert environ == {"PYTHONPYCACHEPREFIX": "/var/cache/mine"}
    assert bytecode_cache.outside_the_tree({}) is None


def test_a_process_a_test_starts_writes_and_reads_bytecode_outside_the_tree():
    """Whatever the shell said: this session's processes compile a module once, never into the tree."""
    code = "import sys; print(sys.flags.dont_write_bytecode, sys.pycache_prefix)"
    flag, prefix = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                  check=True).stdout.split()
    assert flag == "0"
    assert prefix == "None" or not Path(prefix).resolve().is_relative_to(ROOT)
    assert sys.dont_write_bytecode is False
