"""The `hev` command answers at once: `--help` lists every command without importing a stage, a command
imports only its own module, and a bad input to `hev simulate` fails with one line -- the file's own line,
1-based, no Python repr -- before the simulator is loaded."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from stages.cli import app, command_index

REPO = Path(__file__).resolve().parents[1]
HEAVY = ("numba", "pandas", "polars", "torch", "matplotlib", "pymoo")


def _hev(*args: str, cwd: Path = REPO) -> tuple[subprocess.CompletedProcess, set[str]]:
    """Run the app as `hev` does in a fresh interpreter; the heavy modules it had imported when it ended."""
    code = (
        "import sys, atexit\n"
        f"atexit.register(lambda: print('IMPORTED', *[m for m in {HEAVY!r} if m in sys.modules], file=sys.stderr))\n"
        "from stages import cli\n"
        f"sys.argv = ['hev', *{list(args)!r}]\n"
        "cli._register_for(sys.argv[1:])\n"
        "cli.app(prog_name='hev')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=cwd, capture_output=True, text=True, timeout=120)
    line = next(x for x in out.stderr.splitlines() if x.startswith("IMPORTED"))
    return out, set(line.split()[1:])


def test_help_lists_every_command_without_importing_a_stage():
    out, heavy = _hev("--help")
    assert out.returncode == 0, out.stderr
    for name in command_index(REPO):
        assert name in out.stdout
    assert heavy == set()


def test_the_index_read_from_the_sources_is_what_the_modules_register():
    registered = {
        c.name: c.callback.__module__ for c in app.registered_commands if c.callback.__module__ != "stages.cli"
    }
    assert registered == {name: module for name, (module, _) in command_index(REPO).items()}


@pytest.mark.parametrize(
    ("rows", "message"),
    [
        ("40,30,15,3.9,25,78,30\n40,30,,3.9,25,78,30\n", "p_gen_kw is not a number in line 3 (empty)"),
        ("40,30,15,3.9,25,78,30\n40,30,15,3.9,abc,78,30\n", "n_bat is not a number in line 3 (abc)"),
        (
            "40,30,15,3.9,25,78,30\n90,30,15,3.9,25,78,30\n",
            "p_eng_kw=90 in line 3 is outside the design space [25, 70]",
        ),
        ("40,30,15,3.9,25.5,78,30\n", "n_bat=25.5 in line 2 must be an integer"),
    ],
)
def test_a_bad_designs_file_fails_on_its_own_line_before_the_simulator_loads(tmp_path, rows, message):
    designs = tmp_path / "d.csv"
    designs.write_text("p_eng_kw,p_mot_kw,p_gen_kw,i0,n_bat,n_r,n_s\n" + rows)
    out, heavy = _hev(
        "simulate",
        "--designs",
        str(designs),
        "--cycle",
        "udds",
        "--out",
        str(tmp_path / "o.csv"),
        "--params",
        str(REPO / "params.yaml"),
    )
    assert out.returncode == 1
    err = [x for x in out.stderr.splitlines() if not x.startswith("IMPORTED")]
    assert err == [f"error: {designs}: {message}"]
    assert "numba" not in heavy and "np." not in out.stderr


def test_a_bad_cycle_lists_the_valid_names():
    out, heavy = _hev("simulate", "--cycle", "nope", "--out", "o.csv")
    assert "error: --cycle: 'nope' is not one of udds, ftp, hwfet, us06, nedc" in out.stderr
    assert out.returncode == 1 and "numba" not in heavy


def test_simulate_names_the_vehicles_the_simulator_knows():
    from hevlib.sim.vehicles import VEHICLES
    from stages.simulate import VEHICLES as CLI_VEHICLES

    assert CLI_VEHICLES == VEHICLES


@pytest.mark.parametrize("command", ["pareto", "surrogates", "validate", "doe", "optimise nsga3"])
def test_a_bad_params_file_stops_a_stage_before_its_module_loads(tmp_path, command):
    bad = tmp_path / "bad.yaml"
    bad.write_text((REPO / "params.yaml").read_text().replace("  n_pick: 15", "  n_pick: 15\n  n_pik: 3"))
    out, heavy = _hev(*command.split(), "--params", str(bad))
    err = [x for x in out.stderr.splitlines() if not x.startswith("IMPORTED")]
    assert out.returncode == 1 and len(err) == 1 and err[0].startswith("error: ") and "n_pik" in err[0]
    assert heavy == set()  # not even pandas: the stage's module was never imported
    out, _ = _hev(*command.split(), "--params", str(tmp_path / "missing.yaml"))
    assert out.returncode == 1 and "missing.yaml" in out.stderr


class InputDataWarning(UserWarning):
    """Stands in for BoTorch's: a multi-line warning a library raises inside a stage."""


def test_a_stage_sums_up_its_warnings_one_line_per_category(capsys):
    """Two multi-line warnings of one category (and one of another) raised inside a stage come out as one line
    each: the category, the count and the first line of the first message; nothing multi-line is dumped, and
    the summary still comes when the stage fails."""
    import warnings

    import typer

    from stages.common import stage, summarised_warnings, warning_lines

    @stage
    def noisy(fail: bool = False) -> str:
        warnings.warn(
            "Data is not standardized (std = tensor([0.])).\nPlease consider scaling...", InputDataWarning, stacklevel=1
        )
        warnings.warn(
            "Input data is not contained to the unit cube.\nPlease consider min-max...", InputDataWarning, stacklevel=1
        )
        warnings.warn("lbfgs failed to converge", RuntimeWarning, stacklevel=1)
        if fail:
            raise ValueError("bad input")
        return "done"

    assert noisy() == "done"
    err = capsys.readouterr().err.splitlines()
    here = InputDataWarning.__module__.split(".")[0]
    assert err == [
        f"warning: {here}.InputDataWarning x2: Data is not standardized (std = tensor([0.])).",
        "warning: RuntimeWarning x1: lbfgs failed to converge",
    ]
    with pytest.raises(typer.Exit):
        noisy(fail=True)
    err = capsys.readouterr().err.splitlines()
    assert err[0].startswith(f"warning: {here}.InputDataWarning x2: ") and err[-1] == "error: bad input"
    # the filters in force stay: an ignored category stays ignored, an error still raises
    lines: list[str] = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InputDataWarning)
        warnings.simplefilter("error", DeprecationWarning)
        with summarised_warnings(lines.append):
            warnings.warn("quiet", InputDataWarning, stacklevel=1)
            with pytest.raises(DeprecationWarning):
                warnings.warn("loud", DeprecationWarning, stacklevel=1)
    assert lines == [] and warning_lines([]) == []
