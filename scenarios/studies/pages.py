"""The study pages of the documentation: what made each, whether it is older than its inputs, and
their regeneration (``mocap-bench studies``).

A registry (``docs/studies/studies.toml``) lists every page: the commands that make it (``{out}`` and
``{work}`` stand for a fresh output and work directory), which of their output files become which
files of the docs, and the inputs the result depends on (scenario, cohort and room files, sensor
profiles). A page *written* by hand from several runs lists the commands for the reader instead.

Each page carries its provenance on its first line, as an HTML comment holding JSON (the commit, the
command, the date and a fingerprint of every input), followed, after its title, by a visible line
saying the same. A page is *stale* when an input's fingerprint differs from the current one; it then
carries a visible notice saying which input changed and how to regenerate it. A sensor profile's
fingerprint covers its values (floats to 9 significant digits), not the provenance of each value, so
rewording a profile's provenance does not make pages stale, nor do the time constant and camera share
of a body scale that is off (``body_scale_sd`` 0: they change nothing the profile simulates); any
other input's covers its parsed TOML.
"""

from __future__ import annotations

import enum
import hashlib
import json
import re
import shlex
import tempfile
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import date
from pathlib import Path
from typing import Any

from fusion.errors import BadInputError, ScenarioError, UnknownNameError
from fusion.io.atomic import write_bytes_atomic, write_text_atomic
from scenarios.runner import commit_id
from scenarios.toml_tables import build_table, read_toml

REGISTRY = "studies.toml"
"""The registry's file name in the studies folder."""
_MARK = "<!-- study "
_NOTICE = "> **Older than its inputs:**"
_MADE = "*Made by"
_WRITTEN = "*Written from runs"


class Status(enum.Enum):
    """A page against its inputs."""

    FRESH = "fresh"
    STALE = "stale"
    UNRECORDED = "unrecorded"
    """No provenance line: nothing says what made it."""


@dataclass(frozen=True)
class StudyPage:
    """One registered page (a ``[[study]]`` table of the registry).

    Attributes
    ----------
    name : the study's name (``mocap-bench studies --only NAME``).
    page : the Markdown page, relative to the studies folder.
    inputs : repository files the result depends on (``sim/sensor_profiles/*.toml``, scenario, cohort and
        room files), relative to the repository root.
    commands : ``mocap-bench`` command lines (without the program name) run in order; empty for a page
        written by hand.
    copy : output file (relative to ``{out}``) -> docs file (relative to the studies folder); the first
        entry is the page. File names in the page are renamed as the files are.
    written : the runs a hand-written page reports (command lines), shown to the reader.
    """

    name: str
    page: str
    inputs: list[str] = field(default_factory=list)
    commands: list[str] = field(default_factory=list)
    copy: dict[str, str] = field(default_factory=dict)
    written: list[str] = field(default_factory=list)

    @property
    def generated(self) -> bool:
        """Made by its commands alone (else written by hand from runs)."""
        return bool(self.commands)


@dataclass(frozen=True)
class Provenance:
    """What a page says made it."""

    command: str
    commit: str
    date: str
    inputs: dict[str, str]


@dataclass(frozen=True)
class PageStatus:
    """A page's state: fresh, stale (with the inputs that changed) or unrecorded."""

    study: StudyPage
    status: Status
    changed: tuple[str, ...] = ()
    notice_shown: bool = False

    @property
    def honest(self) -> bool:
        """The page shows a notice exactly when it is stale, and says what made it."""
        return self.status is not Status.UNRECORDED and self.notice_shown == (self.status is Status.STALE)


def load_registry(folder: Path) -> list[StudyPage]:
    """The pages registered in ``folder/studies.toml``, each checked (unique names, pages that exist)."""
    data = read_toml(Path(folder) / REGISTRY)
    entries = data.get("study")
    if not isinstance(entries, list) or not entries:
        raise ScenarioError(f"{Path(folder) / REGISTRY}: expected [[study]] tables")
    pages = [build_table(StudyPage, e, f"study[{i}]") for i, e in enumerate(entries)]
    names = [p.name for p in pages]
    if len(set(names)) != len(names):
        raise ScenarioError(f"{Path(folder) / REGISTRY}: study names must be unique, got {names}")
    for p in pages:
        if p.generated and (not p.copy or next(iter(p.copy.values())) != p.page):
            raise ScenarioError(f"study {p.name}: the first copy entry must make its page {p.page}")
    return pages


def _rounded(value: Any) -> Any:
    if isinstance(value, float):
        return float(f"{value:.9g}")
    if isinstance(value, dict):
        return {k: _rounded(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_rounded(v) for v in value]
    return value


def fingerprint(path: Path) -> str:
    """A 12-hex-digit fingerprint of an input file's content (see the module docstring); any file but
    TOML by its bytes; ``missing`` for a file that is not there."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        return "missing"
    except OSError as exc:
        raise BadInputError(f"{path}: cannot fingerprint this input ({exc.strerror or exc})") from None
    if path.suffix != ".toml":
        return hashlib.sha256(raw).hexdigest()[:12]
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise BadInputError(f"{path}: cannot fingerprint this input ({exc})") from None
    if "provenance" in data and "profile" in data:  # a sensor profile: its values, not their sources
        data = {k: v for k, v in data.items() if k != "provenance"}
        data["profile"] = {k: v for k, v in data["profile"].items() if k != "description"}
        tracker = data.get("tracker", {})
        if tracker.get("body_scale_sd", 0) == 0:
            data["tracker"] = {k: v for k, v in tracker.items() if not k.startswith("body_scale_")}
    text = json.dumps(_rounded(data), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def input_fingerprints(study: StudyPage, root: Path) -> dict[str, str]:
    """Each input of ``study`` (relative to ``root``) -> its current :func:`fingerprint`."""
    return {p: fingerprint(Path(root) / p) for p in study.inputs}


def read_provenance(page: Path) -> Provenance | None:
    """The provenance a page records on its first line (None without one)."""
    first = Path(page).read_text(encoding="utf-8").split("\n", 1)[0]
    if not first.startswith(_MARK):
        return None
    try:
        data = json.loads(first[len(_MARK):].removesuffix("-->").strip())
        return Provenance(str(data["command"]), str(data["commit"]), str(data["date"]), dict(data["inputs"]))
    except (ValueError, KeyError, TypeError) as exc:
        raise BadInputError(f"{page}: unreadable provenance line ({exc}); regenerate the page") from None


def page_status(study: StudyPage, folder: Path, root: Path) -> PageStatus:
    """Fresh, stale or unrecorded: the page's recorded fingerprints against the inputs in ``root``."""
    page = Path(folder) / study.page
    if not page.is_file():
        raise BadInputError(f"study {study.name}: page {page} not found; regenerate it (mocap-bench studies "
                            f"--only {study.name})")
    shown = _NOTICE in page.read_text(encoding="utf-8")
    prov = read_provenance(page)
    if prov is None:
        return PageStatus(study, Status.UNRECORDED, notice_shown=shown)
    current = input_fingerprints(study, root)
    changed = tuple(p for p in study.inputs if prov.inputs.get(p) != current[p])
    return PageStatus(study, Status.STALE if changed else Status.FRESH, changed, shown)


def check_pages(folder: Path, root: Path) -> list[PageStatus]:
    """Every registered page's status, and registry problems: a Markdown page in ``folder`` that is not
    registered raises :class:`BadInputError` naming it."""
    studies = load_registry(folder)
    known = {s.page for s in studies} | {c for s in studies for c in s.copy.values()}
    strays = sorted(str(p.relative_to(folder)) for p in Path(folder).rglob("*.md")
                    if str(p.relative_to(folder)) not in known and p.name != "index.md")
    if strays:
        raise BadInputError(f"study pages not in {Path(folder) / REGISTRY}: {', '.join(strays)}; register them")
    return [page_status(s, folder, root) for s in studies]


def stamp(text: str, study: StudyPage, prov: Provenance, changed: tuple[str, ...] = ()) -> str:
    """``text`` with its provenance line, visible provenance and (for ``changed`` inputs) the stale
    notice replaced or added."""
    lines = [ln for ln in text.split("\n") if not ln.startswith((_MARK, _NOTICE, _MADE, _WRITTEN))]
    while lines and not lines[0].strip():
        lines.pop(0)
    if study.generated:
        visible = f"{_MADE} `mocap-bench {prov.command}` at commit {prov.commit} ({prov.date}).*"
    else:
        visible = f"{_WRITTEN} at commit {prov.commit} ({prov.date}):* " + "; ".join(f"`{r}`" for r in study.written)
    block = [visible]
    if changed:
        block.append("")
        how = (f"regenerate with `mocap-bench studies --only {study.name}`" if study.generated else
               f"re-run the runs above, update the page, then `mocap-bench studies --record {study.name}`")
        block.append(f"{_NOTICE} {', '.join(f'`{c}`' for c in changed)} changed since; {how}.")
    title = next((i for i, ln in enumerate(lines) if ln.startswith("# ")), None)
    at = 0 if title is None else title + 1
    body = lines[:at] + ([""] if title is not None else []) + block + [""] + [ln for ln in lines[at:]]
    while len(body) > 1 and body[-1] == "" and body[-2] == "":
        body.pop()
    mark = _MARK + json.dumps({"command": prov.command, "commit": prov.commit, "date": prov.date,
                               "inputs": prov.inputs}, sort_keys=True) + " -->"
    return "\n".join([mark] + _collapse_blank(body))


def _collapse_blank(lines: list[str]) -> list[str]:
    out: list[str] = []
    for ln in lines:
        if ln == "" and out and out[-1] == "":
            continue
        out.append(ln)
    return out


def mark_pages(folder: Path, root: Path) -> list[PageStatus]:
    """Show or remove each recorded page's stale notice as its inputs say; returns the statuses."""
    statuses = check_pages(folder, root)
    for s in statuses:
        if s.status is Status.UNRECORDED or s.honest:
            continue
        page = Path(folder) / s.study.page
        write_text_atomic(page, stamp(page.read_text(encoding="utf-8"), s.study, read_provenance(page), s.changed))
    return check_pages(folder, root)


def regenerate(study: StudyPage, folder: Path, root: Path, main: Callable[[list[str]], int], *,
               today: date | None = None) -> list[Path]:
    """Run ``study``'s commands with ``main`` (the CLI's) in fresh directories and copy its files into
    ``folder``, the page stamped with its provenance; returns the files written."""
    if not study.generated:
        raise BadInputError(f"study {study.name} is written by hand from several runs; run them as the page "
                            "says (mocap-bench studies --list shows them)")
    commit = commit_id(root, outputs=folder)
    with tempfile.TemporaryDirectory(prefix=f"study-{study.name}-") as tmp:
        out, work = Path(tmp) / "out", Path(tmp) / "work"
        work.mkdir()
        for line in study.commands:
            argv = shlex.split(line.format(out=out, work=work))
            status = main(argv)
            if status != 0:
                raise ScenarioError(f"study {study.name}: `mocap-bench {' '.join(argv)}` ended with status "
                                    f"{status}; nothing in {folder} was changed")
        renames = {Path(src).name: Path(dst).name for src, dst in study.copy.items()}
        written = []
        for src, dst in study.copy.items():
            source = out / src
            if not source.is_file():
                raise ScenarioError(f"study {study.name}: the commands wrote no {src}; nothing was changed")
            target = Path(folder) / dst
            target.parent.mkdir(parents=True, exist_ok=True)
            if source.suffix == ".md":
                text = source.read_text(encoding="utf-8")
                for a, b in renames.items():
                    text = re.sub(rf"(?<![\w./-]){re.escape(a)}(?![\w])", b, text)
                if dst == study.page:
                    prov = Provenance(_shown_command(study), commit, str(today or date.today()),
                                      input_fingerprints(study, root))
                    text = stamp(text, study, prov)
                write_text_atomic(target, text)
            else:
                write_bytes_atomic(target, source.read_bytes())
            written.append(target)
    return written


def _shown_command(study: StudyPage) -> str:
    """The commands as a reader runs them (``OUT`` and ``WORK`` for the directories); for a written page,
    the runs it reports."""
    if not study.generated:
        return "; ".join(study.written)
    return " && mocap-bench ".join(c.format(out="OUT", work="WORK") for c in study.commands)


def select(studies: list[StudyPage], names: list[str] | None) -> list[StudyPage]:
    """The studies named (all without names); an unknown name lists the known ones."""
    if not names:
        return studies
    by_name = {s.name: s for s in studies}
    for n in names:
        if n not in by_name:
            raise UnknownNameError("study", n, by_name)
    return [by_name[n] for n in names]


def status_table(statuses: list[PageStatus]) -> str:
    """A Markdown table: page, status, changed inputs, how it is made."""
    rows = ["| study | page | status | changed inputs | made by |", "| --- | --- | --- | --- | --- |"]
    for s in statuses:
        how = (f"`mocap-bench {_shown_command(s.study)}`" if s.study.generated
               else "written from runs: " + _shown_command(s.study))
        rows.append(f"| {s.study.name} | {s.study.page} | {s.status.value} | {', '.join(s.changed) or '-'} | {how} |")
    return "\n".join(rows) + "\n"


def record(study: StudyPage, folder: Path, root: Path, *, today: date | None = None) -> Path:
    """Stamp a hand-written page, just remade from the runs it lists, with the current commit and the
    current fingerprints of its inputs; returns the page."""
    page = Path(folder) / study.page
    if not page.is_file():
        raise BadInputError(f"study {study.name}: page {page} not found")
    prov = Provenance(_shown_command(study), commit_id(root, outputs=folder), str(today or date.today()),
                      input_fingerprints(study, root))
    write_text_atomic(page, stamp(page.read_text(encoding="utf-8"), study, prov))
    return page
