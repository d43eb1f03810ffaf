"""The documentation keeps up with the code.

- every command, argument and option of the command line is documented in ``docs/cli.md``, in the
  section of its command (so a new option fails here until it is documented: that is intended);
- every key the model loader accepts is documented in ``docs/model-format.md``;
- every code name in the glossary of ``docs/conventions.md`` exists in the source;
- every column of ``results.csv`` and every key of ``summary.json`` is described in ``docs/cli.md``;
- the relative links between the docs point to pages and headings that exist.
"""

from __future__ import annotations

import ast
import json
import re
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

import linkdyn
import linkdyn.io as lio
from linkdyn.cli import example_names, main, simulation_example_names

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
SRC = ROOT / "src" / "linkdyn"


def read(name: str) -> str:
    return (DOCS / name).read_text(encoding="utf-8")


def mentions(text: str, token: str) -> bool:
    """``token`` occurs in ``text`` as a whole option or word (``-o`` is not part of ``--outdir``)."""
    return re.search(r"(?<![\w-])" + re.escape(token) + r"(?![\w-])", text) is not None


def sections(text: str) -> list[tuple[int, str, str]]:
    """Markdown sections as (level, heading text without backticks, body up to the next heading
    of the same or a higher level), skipping fenced code blocks."""
    lines = text.splitlines()
    heads, fenced = [], False
    for k, line in enumerate(lines):
        if line.lstrip().startswith("```"):
            fenced = not fenced
        m = None if fenced else re.match(r"(#{1,6})\s+(.*)$", line)
        if m:
            heads.append((k, len(m.group(1)), m.group(2).replace("`", "").strip()))
    out = []
    for n, (k, level, title) in enumerate(heads):
        end = next((k2 for k2, l2, _ in heads[n + 1:] if l2 <= level), len(lines))
        out.append((level, title, "\n".join(lines[k:end])))
    return out


# ------------------------------------------------------------------------------- command line

def commands(group: click.Group, prefix: tuple[str, ...] = ()):
    """(path, command) of every command, recursing into sub-groups."""
    for name, cmd in sorted(group.commands.items()):
        yield prefix + (name,), cmd
        if isinstance(cmd, click.Group):
            yield from commands(cmd, prefix + (name,))


def param_tokens(cmd: click.Command) -> list[str]:
    """Every spelling of every option (``-o``, ``--outdir``), the metavar of every argument and
    every choice of a choice-valued parameter, help option included."""
    ctx = click.Context(cmd, info_name=cmd.name)
    tokens = []
    for p in cmd.get_params(ctx):
        if isinstance(p, click.Option):
            tokens += list(p.opts) + list(p.secondary_opts)
        else:
            tokens.append(p.human_readable_name)
        if isinstance(p.type, click.Choice):
            tokens += [str(c) for c in p.type.choices]
    return tokens


COMMANDS = list(commands(main))


def test_the_cli_has_commands():
    assert {"analyze", "check", "example"} <= {path[-1] for path, _ in COMMANDS}


def test_the_index_names_every_page_and_every_command():
    # the index's cli.md row named four of the commands; cams.md had no row
    text = read("index.md")
    pages = sorted(p.name for p in DOCS.glob("*.md") if p.name != "index.md")
    assert [p for p in pages if f"]({p})" not in text] == []
    row = next(line for line in text.splitlines() if line.startswith("| [cli.md]"))
    assert [c for c in {path[0] for path, _ in COMMANDS} if f"`{c}`" not in row
            and f"`linkdyn {c}`" not in row] == []


@pytest.mark.parametrize("path, cmd", COMMANDS, ids=[" ".join(p) for p, _ in COMMANDS])
def test_every_command_and_option_is_documented(path, cmd):
    text = read("cli.md")
    title = "linkdyn " + " ".join(path)
    found = [body for _, head, body in sections(text)
             if re.search(re.escape(title) + r"(?![\w-])", head)]
    assert found, f"docs/cli.md has no section headed '{title}' (e.g. '## `{title}`')"
    body = found[0]
    missing = [tok for tok in param_tokens(cmd) if not mentions(body, tok)]
    assert not missing, (f"docs/cli.md, section '{title}': document {', '.join(missing)} "
                         f"(see `{title} --help`)")


def test_group_options_are_documented():
    text = read("cli.md")
    missing = [tok for tok in param_tokens(main) if not mentions(text, tok)]
    assert not missing, f"docs/cli.md: document the options of `linkdyn` itself: {missing}"


# ------------------------------------------------------------------------------- model format

def loader_keys() -> dict[str, set[str]]:
    """Keys accepted by the loader: the module's ``SECTIONS`` and ``*_KEYS`` constants (tuples, or
    dicts of kind -> keys), plus the literal key tuples passed to ``_Reader.table`` in the io
    package."""
    found: dict[str, set[str]] = {}
    for name in dir(lio):
        if name != "SECTIONS" and not name.endswith("_KEYS"):
            continue
        value = getattr(lio, name)
        keys = set(value) if not isinstance(value, dict) else set(value) | {
            k for v in value.values() for k in v}
        found[name] = {k for k in keys if isinstance(k, str)}
    literal = set()
    for node in (n for f in sorted(Path(lio.__file__).parent.glob("*.py"))
                 for n in ast.walk(ast.parse(f.read_text(encoding="utf-8")))):
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                and node.func.attr == "table" and len(node.args) >= 3
                and isinstance(node.args[2], ast.Tuple)):
            literal |= {e.value for e in node.args[2].elts
                        if isinstance(e, ast.Constant) and isinstance(e.value, str)}
    found["io table(...) literals"] = literal
    return found


def documented_key(text: str, key: str) -> bool:
    """``key`` is written as a key: in backticks, quoted, as a [section], or as ``key =``."""
    k = re.escape(key)
    return any(re.search(p, text) for p in (
        r"`" + k + r"`", r'"' + k + r'"', r"\[\[?" + k + r"\]\]?", r"(?<![\w.])" + k + r"\s*="))


def test_loader_constants_are_found():
    keys = loader_keys()
    assert {"SECTIONS", "BODY_KEYS", "JOINT_KEYS"} <= set(keys)
    assert "mechanism" in keys["SECTIONS"] and "inertia_about" in keys["BODY_KEYS"]
    assert {"gravity", "length", "cut", "samples"} <= keys["io table(...) literals"]


@pytest.mark.parametrize("group, keys", sorted(loader_keys().items()))
def test_every_model_key_is_documented(group, keys):
    text = read("model-format.md")
    missing = sorted(k for k in keys if not documented_key(text, k))
    assert not missing, f"docs/model-format.md: document the {group} keys {missing}"


def test_every_unit_name_is_documented():
    text = read("model-format.md")
    names = set(lio.LENGTH_UNITS) | set(lio.ANGLE_UNITS)
    missing = sorted(u for u in names if not mentions(text, u))
    assert not missing, f"docs/model-format.md: document the units {missing}"


# ------------------------------------------------------------------------------- glossary

def glossary_names() -> list[str]:
    """Identifiers in the backticked code names (2nd column) of the glossary table."""
    body = next(b for _, head, b in sections(read("conventions.md")) if head == "Glossary")
    rows = [line for line in body.splitlines() if line.startswith("|")][2:]  # skip header, rule
    names = []
    for row in rows:
        cells = [c.strip() for c in row.strip().strip("|").split("|")]
        for span in re.findall(r"`([^`]+)`", cells[1]):
            names += re.findall(r"[A-Za-z_][A-Za-z0-9_]*", span)
    return names


def source_words() -> set[str]:
    words: set[str] = set()
    for f in SRC.rglob("*.py"):
        words |= set(re.findall(r"[A-Za-z_][A-Za-z0-9_]*", f.read_text(encoding="utf-8")))
    return words


def test_every_glossary_code_name_exists_in_the_source():
    names = glossary_names()
    assert len(set(names)) > 40, "the glossary table was not found or lost its code names"
    words = source_words()
    missing = sorted({n for n in names if n not in words})
    assert not missing, f"docs/conventions.md glossary: no such name in src/linkdyn: {missing}"


# ------------------------------------------------------------------------------- outputs

def _run(name: str, tmp_path: Path, command: str = "analyze"):
    """``linkdyn analyze`` (or ``simulate``) on a short run of a bundled example: (csv header,
    summary dict)."""
    model = tmp_path / f"{name}.toml"
    model.write_text(Path(linkdyn.example_path(name)).read_text(encoding="utf-8"),
                     encoding="utf-8")
    out = tmp_path / "out"
    duration = "0.1" if command == "analyze" else "0.02"
    res = CliRunner().invoke(main, [command, str(model), "-o", str(out), "--samples", "9",
                                    "--duration", duration])
    assert res.exit_code == 0, res.output
    header = (out / "results.csv").read_text(encoding="utf-8").splitlines()[0].split(",")
    return header, json.loads((out / "summary.json").read_text(encoding="utf-8"))


def _keys(x, names: set[str]):
    """All dict keys of a JSON value, recursively, except model names (joints, bodies)."""
    if isinstance(x, dict):
        for k, v in x.items():
            if k not in names:
                yield k
            yield from _keys(v, names)
    elif isinstance(x, list):
        for v in x:
            yield from _keys(v, names)


@pytest.mark.parametrize("command, name", [("analyze", n) for n in example_names()]
                         + [("simulate", n) for n in simulation_example_names()])
def test_results_columns_and_summary_keys_are_documented(command, name, tmp_path):
    text = read("cli.md")
    header, summary = _run(name, tmp_path, command)
    mech = linkdyn.load(linkdyn.example_path(name))
    labels = set(linkdyn.loads.labels(mech))   # loads.<name> or loads[<k>]
    # a column is documented by its pattern: q_<joint>, x_<body>.<point>, power_loads.<name>,
    # or its exact name
    patterns = set()
    for col in header:
        m = re.match(r"([A-Za-z]+)_(.+)$", col)
        known = m and (m.group(2) in {j.name for j in mech.joints} | {b.name for b in mech.bodies}
                       | labels or "." in m.group(2))
        label = next((x for x in labels if col.endswith(f"_{x}")), None)
        if label:
            patterns.add(col[:-len(label)] + "loads.<")
        else:
            patterns.add(f"{m.group(1)}_<" if known else col)
    missing = sorted(p for p in patterns if (p + ">" if p.endswith("<") else p) not in text
                     and not (p.endswith("<") and p in text))
    assert not missing, f"docs/cli.md: document the results.csv columns {missing}"
    names = {j.name for j in mech.joints} | {b.name for b in mech.bodies} | labels
    keys = sorted(set(_keys(summary, names)))
    missing = [k for k in keys if f"`{k}`" not in text]
    assert not missing, f"docs/cli.md: document the summary.json keys {missing}"


# ------------------------------------------------------------------------------- links

def anchors(text: str) -> set[str]:
    """GitHub's anchors of the headings of a page: lower case, punctuation dropped, spaces to '-'."""
    out = set()
    for _, title, _ in sections(text):
        slug = re.sub(r"[^\w\- ]", "", title.lower()).replace(" ", "-")
        out.add(slug)
    return out


@pytest.mark.parametrize("page", sorted(p.name for p in DOCS.glob("*.md")))
def test_relative_links_point_to_existing_pages_and_headings(page):
    text = read(page)
    bad = []
    for target, anchor in re.findall(r"\]\(([^)#\s]*)(?:#([^)\s]*))?\)", text):
        if target.startswith(("http:", "https:", "mailto:")):
            continue
        if target and not target.endswith(".md"):
            continue
        if target and not (DOCS / target).is_file():
            bad.append(target)
        elif anchor and anchor not in anchors(read(target) if target else text):
            bad.append(f"{target}#{anchor}")
    assert not bad, f"docs/{page}: broken links {sorted(set(bad))}"


# ------------------------------------------------------------------------------- examples in the docs

def _fenced_after(text: str, marker: str) -> str:
    """The first fenced block after ``marker`` in ``text``."""
    start = text.index("```", text.index(marker))
    start = text.index("\n", start) + 1
    return text[start:text.index("```", start)]


def _same_text(doc: str, got: str) -> None:
    """Line by line and word by word; numbers to 4 digits, and two numbers below 1e-9 (rounding
    residuals) count as equal."""
    num = re.compile(r"^[-+(]?\d[\d.e+-]*")
    doc_lines, got_lines = doc.strip().splitlines(), got.strip().splitlines()
    assert len(doc_lines) == len(got_lines), (doc, got)
    for dl, gl in zip(doc_lines, got_lines):
        dw = re.findall(r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?|[^\s\d]+", dl)
        gw = re.findall(r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?|[^\s\d]+", gl)
        assert len(dw) == len(gw), (dl, gl)
        for a, b in zip(dw, gw):
            if num.match(a) and num.match(b):
                x, y = float(a), float(b)
                assert abs(x) < 1e-9 and abs(y) < 1e-9 or x == pytest.approx(y, rel=1e-3), (dl, gl)
            else:
                assert a == b, (dl, gl)


def test_cli_sample_output_is_what_the_bundled_model_prints(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "hoeken.toml").write_text(linkdyn.example_path("hoeken").read_text("utf-8"))
    res = CliRunner().invoke(main, ["analyze", "hoeken.toml", "-o", "out/hoeken"])
    assert res.exit_code == 0, res.output
    _same_text(_fenced_after(read("cli.md"), "`linkdyn analyze hoeken.toml -o out/hoeken` prints"),
               res.output)


def test_cli_rocker_driven_example_fails_as_documented(tmp_path, monkeypatch):
    # the documented sed edits of the bundled Hoeken model, then the documented error
    block = _fenced_after(read("cli.md"), "A model driven past a position it cannot reach")
    text = linkdyn.example_path("hoeken").read_text("utf-8")
    for old, new in re.findall(r"-e 's/(.*?)/(.*?)/'", block):
        old = old.replace("\\[", "[").replace("\\]", "]").lstrip("^")
        assert old in text, old
        text = text.replace(old, new, 1)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "rocker_driven.toml").write_text(text)
    res = CliRunner().invoke(main, ["analyze", "rocker_driven.toml", "--duration", "4"])
    assert res.exit_code == 3
    want = next(ln for ln in block.splitlines() if ln.startswith("error:"))
    _same_text(want, res.output.strip())
    assert not (tmp_path / "out").exists()


def test_model_format_complete_example_is_the_bundled_hoeken(tmp_path):
    import numpy as np
    block = _fenced_after(read("model-format.md"), "## A complete example")
    (tmp_path / "doc.toml").write_text(block)
    doc, bundled = linkdyn.load(tmp_path / "doc.toml"), linkdyn.load(linkdyn.example_path("hoeken"))
    t = np.linspace(0.0, 4 / 3, 61)
    a, b = linkdyn.analyze(doc, t).columns, linkdyn.analyze(bundled, t).columns
    assert list(a) == list(b)
    for k in b:
        np.testing.assert_allclose(a[k], b[k], rtol=0, atol=1e-12 * np.max(np.abs(b[k])) + 1e-300,
                                   err_msg=k)
