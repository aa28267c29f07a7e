"""Every registry against its documentation: docs/architecture.md lists exactly the entries
of each registry (generators, techniques, LOD schemes, static meshers, exporters, mesh
formats, benchmark cases, CLI commands), the README names every generator, LOD scheme,
static mesher and exporter, and the command table is exactly what the ``cli/cmd_*.py``
modules register."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import typer.main

from terrascape.bench import available_cases
from terrascape.cli.commands import COMMANDS
from terrascape.export import destinations
from terrascape.generate.registry import generator_names
from terrascape.io.mesh import MESH_FORMATS
from terrascape.lod.schemes import SCHEMES
from terrascape.lod.static_meshers import STATIC_MESHERS
from terrascape.render.techniques import technique_names

ROOT = Path(__file__).resolve().parents[2]
ARCHITECTURE = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
README = (ROOT / "README.md").read_text(encoding="utf-8")

#: Section title in "What the registries hold" → the registry's entries, read at test time.
REGISTRIES = {
    "Generators": lambda: generator_names(),
    "Techniques": lambda: technique_names(),
    "LOD schemes": lambda: list(SCHEMES),
    "Static meshers": lambda: list(STATIC_MESHERS),
    "Exporters": lambda: destinations(),
    "Mesh formats": lambda: list(MESH_FORMATS),
    "Benchmark cases": lambda: available_cases(),
    "CLI commands": lambda: list(COMMANDS),
}


def documented(title: str) -> list[str]:
    """The names a "### title (...)" section of docs/architecture.md lists: every `name`
    of a bullet before its " — " description."""
    holds = ARCHITECTURE.split("## What the registries hold", 1)
    assert len(holds) == 2, "docs/architecture.md lacks '## What the registries hold'"
    match = re.search(rf"^### {re.escape(title)}\b.*?$(.*?)(?=^##|\Z)", holds[1],
                      flags=re.MULTILINE | re.DOTALL)
    assert match, f"docs/architecture.md lacks the section '### {title}'"
    names = []
    for bullet in re.split(r"^- ", match.group(1), flags=re.MULTILINE)[1:]:
        names += re.findall(r"`([^`]+)`", bullet.split(" — ", 1)[0])
    return names


@pytest.mark.parametrize("title", REGISTRIES)
def test_architecture_lists_exactly_the_registry(title: str) -> None:
    entries = list(REGISTRIES[title]())
    listed = documented(title)
    assert entries, title
    assert len(listed) == len(set(listed)), f"{title}: listed twice: {listed}"
    missing = sorted(set(entries) - set(listed))
    gone = sorted(set(listed) - set(entries))
    assert not missing, f"docs/architecture.md '{title}' lacks {missing}"
    assert not gone, f"docs/architecture.md '{title}' lists {gone}, which the registry lacks"


def test_commands_are_listed_in_help_order() -> None:
    assert documented("CLI commands") == list(COMMANDS)


@pytest.mark.parametrize("title", ["Generators", "LOD schemes", "Static meshers", "Exporters"])
def test_readme_names_every_entry(title: str) -> None:
    flat = README.replace("_", " ")
    missing = [name for name in REGISTRIES[title]()
               if not re.search(rf"\b{re.escape(name.replace('_', ' '))}\b", flat)]
    assert not missing, f"README.md does not name the {title.lower()} {missing}"


def test_the_section_parser_reads_a_known_list() -> None:  # the checks above cannot be vacuous
    assert documented("LOD schemes") == ["roam", "turner", "geomipmap"]
    with pytest.raises(AssertionError, match="lacks the section"):
        documented("Spaceships")


def _registered_by_module() -> dict[str, set[str]]:
    """Command name → the ``cli`` modules whose functions it runs, after importing every
    ``cmd_*`` module."""
    from terrascape.cli.app import app, load_command_modules

    load_command_modules()
    found: dict[str, set[str]] = {}
    for info in app.registered_commands:
        name = info.name or typer.main.get_command_name(info.callback.__name__)
        found.setdefault(name, set()).add(info.callback.__module__.rsplit(".", 1)[-1])
    for group in app.registered_groups:
        modules = {c.callback.__module__.rsplit(".", 1)[-1]
                   for c in group.typer_instance.registered_commands}
        found.setdefault(group.name, set()).update(modules)
    return found


def test_command_table_is_what_the_modules_register() -> None:
    registered = _registered_by_module()
    assert sorted(registered) == sorted(COMMANDS), (
        "cli/commands.py COMMANDS must list every command the cmd_*.py modules register")
    for name, modules in registered.items():
        assert modules <= set(COMMANDS[name].modules), (
            f"{name!r} is defined in {sorted(modules)}, the table says "
            f"{COMMANDS[name].modules}")


NOT_USERS_WORDS = re.compile(r"seed \d{3}|§|MISSION|\b[HRTP]\d+\b")


@pytest.mark.parametrize("name", COMMANDS)
def test_each_summary_is_one_line_in_the_users_words(name: str) -> None:
    summary = COMMANDS[name].summary
    assert summary and "\n" not in summary and len(summary) <= 110
    assert summary.endswith(".")
    assert not NOT_USERS_WORDS.search(summary)
