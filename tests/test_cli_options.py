"""Options shared by several commands are defined once (``polywear.cli.common``): option
groups expand in place, ``--tir`` comes last, and every command shows the same option the
same way."""

from __future__ import annotations

from typing import Annotated

import pytest
import typer
from typer.testing import CliRunner

from polywear.cli import common
from polywear.cli.common import Inputs, Outputs, add_shared_options


def _toy_app(seen: dict) -> typer.Typer:
    """One command with an option before, between and after the two groups."""
    app = typer.Typer()

    @app.command("toy")
    def toy(
        first: Annotated[int, typer.Option("--first")] = 1,
        inputs: Inputs = Inputs(),
        middle: Annotated[int, typer.Option("--middle")] = 2,
        outputs: Outputs = Outputs("Write the toy (.nc).", (".nc",)),
    ) -> None:
        seen.update(first=first, middle=middle, inputs=inputs, outputs=outputs, tir=common._TIR_PATH.get())

    @app.command("bare")
    def bare(outputs: Outputs = Outputs(takes_plot=False)) -> None:
        seen.update(outputs=outputs)

    add_shared_options(app)
    return app


def test_groups_expand_in_place_and_tir_comes_last():
    cli = typer.main.get_command(_toy_app({}))
    names = {name: [p.name for p in cmd.params] for name, cmd in cli.commands.items()}
    assert names["toy"] == ["first", "config", "set_", "middle", "json_", "plot", "out", "quiet", "tir"]
    assert names["bare"] == ["json_", "quiet"]  # no --plot, no --out, no --config: no --tir
    out = next(p for p in cli.commands["toy"].params if p.name == "out")
    assert out.opts == ["--out", "-o"] and out.help == "Write the toy (.nc)."


def test_the_command_receives_the_values_as_one_object_per_group(tmp_path):
    seen: dict = {}
    app = _toy_app(seen)
    tir = tmp_path / "t.tir"
    result = CliRunner().invoke(app, ["toy", "--middle", "5", "-s", "a.b=1", "--set", "c.d=2", "--json",
                                      "-o", str(tmp_path / "x.nc"), "--tir", str(tir)])
    assert result.exit_code == 0, result.output
    assert seen["first"] == 1 and seen["middle"] == 5
    assert seen["inputs"] == Inputs(config=None, set_=["a.b=1", "c.d=2"])
    assert seen["outputs"] == Outputs("Write the toy (.nc).", (".nc",), json_=True, out=tmp_path / "x.nc")
    assert seen["tir"] == tir and common._TIR_PATH.get() is None  # set for the call only
    result = CliRunner().invoke(app, ["bare", "-q"])
    assert result.exit_code == 0 and seen["outputs"] == Outputs(takes_plot=False, quiet=True)


def test_outputs_write_what_was_asked(tmp_path, capsys):
    written = []
    outputs = Outputs("Write.", (".txt",), out=tmp_path / "a.txt", plot=None, quiet=True)
    outputs.write(lambda path: written.append(path) or path.write_text("x"), lambda: 1 / 0)  # no --plot: not drawn
    assert (tmp_path / "a.txt").read_text() == "x" and len(written) == 1 and written[0] != tmp_path / "a.txt"
    Outputs(plot=tmp_path / "b.png").write(make_figure=None)  # nothing to draw: no file
    assert not (tmp_path / "b.png").exists()
    Outputs(json_=True).show({"a": 1}, lambda summary: 1 / 0)
    Outputs().show({"a": 1}, lambda summary: print("text", summary["a"]))
    assert capsys.readouterr().out == '{\n  "a": 1\n}\ntext 1\n'


def test_a_shared_option_reads_the_same_in_every_command():
    """--config, --set, --tir, --json, --plot, --quiet: one help text and the same names
    wherever they appear; --out always has -o."""
    from polywear.cli.app import app

    seen: dict[str, set] = {}

    def walk(cmd, path):
        for name, sub in (getattr(cmd, "commands", None) or {}).items():
            walk(sub, [*path, name])
        for p in getattr(cmd, "params", []):
            if p.opts[0] in ("--config", "--set", "--tir", "--json", "--plot", "--quiet"):
                seen.setdefault(p.opts[0], set()).add((tuple(p.opts), p.help))
            if p.opts[0] == "--out":
                assert "-o" in p.opts, path

    walk(typer.main.get_command(app), [])
    assert set(seen) == {"--config", "--set", "--tir", "--json", "--plot", "--quiet"}
    assert all(len(forms) == 1 for forms in seen.values()), {k: v for k, v in seen.items() if len(v) > 1}


def test_user_errors_become_one_line():
    with pytest.raises(common.UserError, match="^wear map: bad$"):
        with common.user_errors(ValueError, prefix="wear map: "):
            raise ValueError("bad")
    with pytest.raises(KeyError):  # other kinds pass through
        with common.user_errors(ValueError):
            raise KeyError("k")
