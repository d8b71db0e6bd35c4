"""An assignment's problems as quiz pools for the LMS's own quiz engine: Moodle XML or Canvas QTI 1.2.

Per problem, N variants drawn as students' sheets are (course, salt, a quiz-only id), each with its
statement, figure (an embedded PNG with its text alternative), the sign convention and, per answer
key, one numerical answer in the key's unit whose ABSOLUTE tolerance is the band the grader gives
that variant (`gradekit.solving.keys.Tolerance.band` of the key entry, which `gradekit.assignment.keys_for`
makes as for a student).

Moodle: a category per problem holding one Cloze question per variant, a NUMERICAL box per answer
(`question/format/xml/format.php` imports it through `qtype_multianswer_extract_question`). Canvas:
a QTI 1.2 package (imsmanifest.xml, one assessment per problem, a question group per answer key
that draws one of the N variants, each a ``numerical_question`` with explicit lower and upper
bounds), images in the package.
"""

from __future__ import annotations

import base64
import hashlib
import html
import io
import math
import zipfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING
from xml.sax.saxutils import escape, quoteattr

from gradekit.errors import GradekitError
from gradekit.solving.keys import KeyEntry
from gradekit.units import pretty

if TYPE_CHECKING:
    from gradekit.assignment import Assignment

FORMATS = ("moodle-xml", "canvas-qti")
MAX_VARIANTS = 500


@dataclass(frozen=True)
class Picture:
    """A figure of a variant: its file name in the export, PNG bytes, text alternative and caption (the
    position it shows, for a problem of several)."""

    name: str
    png: bytes
    alt: str
    caption: str = ""


@dataclass(frozen=True)
class QuizVariant:
    """One variant of one problem as a quiz question: the statement (plain text), its figures and
    the key entries (value, unit, tolerance with its floor resolved, sign convention)."""

    label: str
    title: str
    number: int
    statement: str
    pictures: tuple[Picture, ...]
    entries: tuple[KeyEntry, ...]


def quiz_student(number: int) -> str:
    """The id the quiz's *number*-th variant is drawn for: no roster id looks like it, so a quiz
    variant is never a student's sheet."""
    return f"quiz:{number}"


def quiz_variants(asg: Assignment, n: int) -> list[list[QuizVariant]]:
    """Per problem of the assignment *asg*, *n* variants as quiz questions: variant k is the one drawn
    for `quiz_student` (k), and one that repeats an earlier one's values is left out (a problem
    without random parameters gives one)."""
    from gradekit.assignment import keys_for, student_variant
    from gradekit.statement import render_statement

    if not 1 <= n <= MAX_VARIANTS:
        raise GradekitError(f"expected from 1 to {MAX_VARIANTS} variants, got {n}", field="--variants")
    out = []
    for item in asg.items:
        seen: set[tuple] = set()
        variants = []
        for k in range(1, n + 1):
            v = student_variant(asg, item, quiz_student(k))
            values = tuple(sorted(v.values.items()))
            if values in seen:
                continue
            seen.add(values)
            # an answer the bank marks for hand checking has no band that grades it: not in the pool
            entries = tuple(e for e in keys_for(asg, item, quiz_student(k), v, with_mistakes=False)
                            if not e.hand_check)
            variants.append(QuizVariant(item.label, item.problem.title, k, render_statement(v.problem, v.result.values),
                                        _pictures(v.result, f"{item.label}-v{k}"), entries))
        out.append(variants)
    return out


def _pictures(result, stem: str) -> tuple[Picture, ...]:
    """The variant's scene per case, as PNG, with the text alternative the sheet gives it
    (`gradekit.figures.scene_described`: what is drawn, never a solved answer)."""
    from gradekit import figures

    cases = [c.name for c in result.cases] if len(result.cases) > 1 else [None]
    out = []
    for case in cases:
        png = figures.to_png(figures.scene(result, case))
        _svg, alt = figures.scene_described(result, case)
        out.append(Picture(f"{stem}{'-' + _slug(case) if case else ''}.png", png, alt,
                           f"Position {case}:" if case else ""))
    return tuple(out)


def _slug(text: str) -> str:
    return "".join(c if c.isalnum() else "-" for c in text).strip("-") or "case"


def number(value: float) -> str:
    """A number as the shortest text that reads back as the same float (both LMSs parse it)."""
    if not math.isfinite(value):
        raise GradekitError(f"expected a finite key value, got {value!r}")
    return repr(float(value))


def band(entry: KeyEntry) -> float:
    """The absolute tolerance of *entry* for its variant: the grader's band (`Tolerance.band`)."""
    return entry.tolerance.band(entry.value)


def _answer_line(entry: KeyEntry) -> str:
    """The text before an answer box: what is asked, with its sign convention."""
    asked = entry.description or entry.key
    sign = f" ({entry.sign_convention})" if entry.sign_convention else ""
    return f"{entry.key.split('.', 1)[-1]}: {asked}{sign}"


def _statement_html(v: QuizVariant, src: dict[str, str]) -> str:
    """The question's HTML: the statement's paragraphs, the figures, the note on tolerances."""
    paragraphs = [" ".join(p.split()) for p in v.statement.split("\n\n") if p.strip()]
    parts = [f"<p>{html.escape(p)}</p>" for p in paragraphs]
    parts += [f'<p>{html.escape(p.caption) + "<br>" if p.caption else ""}'
              f'<img src="{html.escape(src[p.name])}" alt="{html.escape(p.alt)}"></p>' for p in v.pictures]
    parts.append("<p>Give each answer in the unit shown, with the sign convention stated.</p>")
    return "\n".join(parts)


def _cdata(text: str) -> str:
    """*text* in CDATA sections (split where it holds ``]]>``)."""
    return "<![CDATA[" + text.replace("]]>", "]]]]><![CDATA[>") + "]]>"


def _weights(entries: Sequence[KeyEntry]) -> list[int]:
    """Whole-number Cloze weights in the proportion of the answers' points (2.5 and 5 -> 1 and 2)."""
    hundredths = [max(1, round(e.points * 100)) for e in entries]
    g = math.gcd(*hundredths)
    return [h // g for h in hundredths]


def moodle_xml(pools: Sequence[Sequence[QuizVariant]], title: str) -> str:
    """Moodle XML: per problem a category ``$course$/top/<title>/<label: problem title>`` and one Cloze
    question per variant, each answer a ``{w:NUMERICAL:%100%value:tolerance}`` box."""
    out = ['<?xml version="1.0" encoding="UTF-8"?>', "<quiz>"]
    for pool in pools:
        if not pool:
            continue
        first = pool[0]
        category = f"$course$/top/{_category_part(title)}/{_category_part(f'{first.label}: {first.title}')}"
        out += ['  <question type="category">', f"    <category><text>{escape(category)}</text></category>",
                "  </question>"]
        for v in pool:
            src = {p.name: f"@@PLUGINFILE@@/{p.name}" for p in v.pictures}
            boxes = [f"<p>{html.escape(_answer_line(e))}: {{{w}:NUMERICAL:%100%{number(e.value)}:{number(band(e))}}}"
                     f" {html.escape(pretty(e.unit))}</p>" for e, w in zip(v.entries, _weights(v.entries), strict=True)]
            text = _statement_html(v, src) + "\n" + "\n".join(boxes)
            files = "".join(f'\n      <file name={quoteattr(p.name)} path="/" encoding="base64">'
                            f"{base64.b64encode(p.png).decode()}</file>" for p in v.pictures)
            out += [
                '  <question type="cloze">',
                f"    <name><text>{escape(f'{v.label} variant {v.number}: {v.title}')}</text></name>",
                f'    <questiontext format="html">\n      <text>{_cdata(text)}</text>{files}\n    </questiontext>',
                '    <generalfeedback format="html"><text></text></generalfeedback>',
                f"    <defaultgrade>{number(sum(e.points for e in v.entries))}</defaultgrade>",
                "    <penalty>0.3333333</penalty>",
                "    <hidden>0</hidden>",
                "  </question>",
            ]
    out.append("</quiz>")
    return "\n".join(out) + "\n"


def _category_part(text: str) -> str:
    """A category name as one part of Moodle's ``/``-separated path (a ``/`` in it doubled, as Moodle's
    own export writes it)."""
    return " ".join(text.split()).replace("/", "//")


def _ident(*parts: object) -> str:
    return "g" + hashlib.sha256("\x1f".join(map(str, parts)).encode()).hexdigest()[:24]


def canvas_qti(pools: Sequence[Sequence[QuizVariant]], title: str) -> bytes:
    """A Canvas QTI 1.2 package (zip): imsmanifest.xml, one assessment per problem with a question group
    per answer key (pick 1 of the N variants), images under ``images/``."""
    buffer = io.BytesIO()
    resources = []
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as z:
        for pool in pools:
            if not pool:
                continue
            first = pool[0]
            ident = _ident(title, first.label)
            xml = _assessment(pool, ident, f"{title}: {first.label}: {first.title}")
            images = [f"images/{p.name}" for v in pool for p in v.pictures]
            _write(z, f"{ident}/{ident}.xml", xml.encode("utf-8"))
            for v in pool:
                for p in v.pictures:
                    _write(z, f"images/{p.name}", p.png)
            files = "".join(f'<file href="{h}"/>' for h in [f"{ident}/{ident}.xml", *images])
            resources.append(f'<resource identifier="{ident}" type="imsqti_xmlv1p2">{files}</resource>')
        manifest = (
            '<?xml version="1.0" encoding="UTF-8"?>\n'
            f'<manifest identifier="{_ident(title)}" xmlns="http://www.imsglobal.org/xsd/imscp_v1p1">\n'
            f"  <metadata><schema>IMS Content</schema><schemaversion>1.1.3</schemaversion></metadata>\n"
            "  <organizations/>\n"
            f"  <resources>{''.join(resources)}</resources>\n</manifest>\n"
        )
        _write(z, "imsmanifest.xml", manifest.encode("utf-8"))
    return buffer.getvalue()


def _write(z: zipfile.ZipFile, name: str, data: bytes) -> None:
    info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))  # the same bytes every run
    info.compress_type = zipfile.ZIP_DEFLATED
    z.writestr(info, data)


def _field(label: str, entry: str) -> str:
    return (f"<qtimetadatafield><fieldlabel>{label}</fieldlabel><fieldentry>{escape(entry)}</fieldentry>"
            "</qtimetadatafield>")


def _assessment(pool: Sequence[QuizVariant], ident: str, title: str) -> str:
    out = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        '<questestinterop xmlns="http://www.imsglobal.org/xsd/ims_qtiasiv1p2">',
        f"  <assessment ident={quoteattr(ident)} title={quoteattr(title)}>",
        f"    <qtimetadata>{_field('cc_maxattempts', '1')}</qtimetadata>",
        '    <section ident="root_section">',
    ]
    for i, entry in enumerate(pool[0].entries):
        key = entry.key
        out += [
            f"      <section ident={quoteattr(_ident(ident, key))} title={quoteattr(key)}>",
            "        <selection_ordering><selection><selection_number>1</selection_number><selection_extension>"
            f"<points_per_item>{number(entry.points)}</points_per_item></selection_extension></selection>"
            "</selection_ordering>",
        ]
        for v in pool:
            e = v.entries[i]
            out.append(_item(v, e, _ident(ident, key, v.number)))
        out.append("      </section>")
    out += ["    </section>", "  </assessment>", "</questestinterop>"]
    return "\n".join(out) + "\n"


def _item(v: QuizVariant, e: KeyEntry, ident: str) -> str:
    """A Canvas ``numerical_question``: the statement, figure and one answer range [value − band,
    value + band]."""
    src = {p.name: f"../images/{p.name}" for p in v.pictures}
    text = _statement_html(v, src) + f"\n<p>{html.escape(_answer_line(e))}, in {html.escape(pretty(e.unit))}.</p>"
    width = band(e)
    return (
        f"        <item ident={quoteattr(ident)} title={quoteattr(f'{v.label} variant {v.number}: {e.key}')}>\n"
        f"          <itemmetadata><qtimetadata>{_field('question_type', 'numerical_question')}"
        f"{_field('points_possible', number(e.points))}</qtimetadata></itemmetadata>\n"
        f'          <presentation><material><mattext texttype="text/html">{escape(text)}</mattext></material>'
        '<response_str ident="response1" rcardinality="Single"><render_fib fibtype="Decimal">'
        '<response_label ident="answer1"/></render_fib></response_str></presentation>\n'
        '          <resprocessing><outcomes><decvar maxvalue="100" minvalue="0" varname="SCORE" vartype="Decimal"/>'
        '</outcomes><respcondition continue="No"><conditionvar>'
        f'<vargte respident="response1">{number(e.value - width)}</vargte>'
        f'<varlte respident="response1">{number(e.value + width)}</varlte>'
        '</conditionvar><setvar action="Set" varname="SCORE">100</setvar></respcondition></resprocessing>\n'
        "        </item>"
    )


def export_quiz(assignment: Path | str, fmt: str, n: int, out: Path | str, bank: Path | str | None = None) -> Path:
    """Write *assignment*'s quiz pools of *n* variants in *fmt* (`FORMATS`) to *out* and return it."""
    from gradekit.assignment import load_assignment
    from gradekit.csvsafe import atomic_write

    if fmt not in FORMATS:
        raise GradekitError(f"expected a format among {', '.join(FORMATS)}, got {fmt!r}", field="--format")
    asg = load_assignment(assignment, bank)
    pools = quiz_variants(asg, n)
    out = Path(out)
    data = moodle_xml(pools, asg.title).encode("utf-8") if fmt == "moodle-xml" else canvas_qti(pools, asg.title)
    atomic_write(out, data)
    return out
