"""The combined PDFs: parts concatenated in order, each on an odd page under a bookmark named by
its title, every bookmark kept and pointing at its own page of the combined file, and the parts'
tags kept (structure tree, language, /MarkInfo)."""

from __future__ import annotations

from pathlib import Path

import pikepdf
import pytest

from gradekit.documents import engine, typeset


def _part(folder: Path, name: str, pages: int) -> Path:
    """A Typst PDF/UA-1 of *pages* pages titled *name*, a level-1 heading on each, a level-2 one under
    the last, and a table with a header row on the first."""
    body = f'#set document(title: "{name}")\n#set text(lang: "en")\n'
    body += f"#table(columns: 2, table.header([{name} key], [value]), [a], [1])\n"
    body += "\n".join(f"= {name} page {i + 1}\n#pagebreak()" for i in range(pages - 1))
    body += f"\n= {name} page {pages}\n== {name} detail\n"
    path = folder / f"{name}.pdf"
    path.write_bytes(typeset.Compiler(folder).pdf(body))
    return path


def _bookmarks(pdf: pikepdf.Pdf) -> list[tuple[int, str, int]]:
    """(depth, title, page index) of every bookmark, in outline order."""
    pages = {p.obj.objgen: i for i, p in enumerate(pdf.pages)}
    found = []
    with pdf.open_outline() as outline:
        def walk(items, depth):
            for item in items:
                found.append((depth, item.title, pages[item.destination[0].objgen]))
                walk(item.children, depth + 1)
        walk(outline.root, 0)
    return found


@pytest.fixture(scope="module")
def parts(tmp_path_factory) -> list[Path]:
    folder = tmp_path_factory.mktemp("parts")
    return [_part(folder, "A", 3), _part(folder, "B", 2), _part(folder, "C", 1)]


def test_each_part_starts_on_an_odd_page_with_its_bookmarks_on_its_pages(parts, tmp_path):
    target = tmp_path / "all.pdf"
    engine.concatenate_pdfs(target, parts, "All", "MEG373")
    with pikepdf.Pdf.open(target) as pdf:
        # A: pages 1-3, a blank 4th, B: 5-6, C: 7 (0-based 0-2, 4-5, 6)
        assert len(pdf.pages) == 7
        assert pdf.pages[3].obj.Contents.read_bytes() == b""
        starts = {"A": 0, "B": 4, "C": 6}
        expected = []
        for name, count in (("A", 3), ("B", 2), ("C", 1)):
            expected.append((0, name, starts[name]))
            expected += [(1, f"{name} page {i + 1}", starts[name] + i) for i in range(count)]
            expected.append((2, f"{name} detail", starts[name] + count - 1))
        assert _bookmarks(pdf) == expected
        assert str(pdf.docinfo["/Title"]) == "All"
        # every page's content is the part's own, in order
        with pikepdf.Pdf.open(parts[1]) as b:
            assert pdf.pages[5].obj.Contents.read_bytes() == b.pages[1].obj.Contents.read_bytes()


def test_the_same_parts_give_the_same_bytes(parts, tmp_path):
    engine.concatenate_pdfs(tmp_path / "1.pdf", parts, "All", "MEG373")
    engine.concatenate_pdfs(tmp_path / "2.pdf", parts, "All", "MEG373")
    assert (tmp_path / "1.pdf").read_bytes() == (tmp_path / "2.pdf").read_bytes()


def test_a_bookmark_without_a_page_of_its_part_goes_to_the_part_start(parts, tmp_path):
    """A named destination's target is not copied with the part: its bookmark opens the part."""
    with pikepdf.Pdf.open(parts[1]) as b:
        b.Root.Outlines.First.Dest = pikepdf.String("nowhere")
        b.save(tmp_path / "B-named.pdf")
    engine.concatenate_pdfs(tmp_path / "all.pdf", [parts[0], tmp_path / "B-named.pdf"], "All", "MEG373")
    with pikepdf.Pdf.open(tmp_path / "all.pdf") as pdf:
        assert (1, "B page 1", 4) in _bookmarks(pdf)


def test_what_a_part_s_pages_inherit_goes_with_them(parts, tmp_path):
    """A part whose page size and resources sit on its page tree, not on its pages (a direct and an
    indirect value): every copied page still has them (qpdf pushes them onto a page it copies)."""
    with pikepdf.Pdf.open(parts[1]) as b:
        for page in b.pages:
            res = page.obj.Resources
            del page.obj["/MediaBox"]
            del page.obj["/Resources"]
        b.Root.Pages.MediaBox = pikepdf.Array([0, 0, 300, 400])
        b.Root.Pages.Resources = b.make_indirect(res)
        b.save(tmp_path / "B-inherits.pdf")
    engine.concatenate_pdfs(tmp_path / "all.pdf", [parts[0], tmp_path / "B-inherits.pdf"], "All", "MEG373")
    with pikepdf.Pdf.open(tmp_path / "all.pdf") as pdf:
        assert len(pdf.pages) == 6  # A 3, a blank, B 2
        assert [list(map(float, p.mediabox)) for p in pdf.pages[4:]] == [[0, 0, 300, 400]] * 2
        assert all("/Font" in p.obj.Resources for p in pdf.pages[4:])


def _elements(node) -> list:
    """Every structure element under *node*, depth first."""
    kids = node.get("/K")
    kids = list(kids) if isinstance(kids, pikepdf.Array) else [kids] if kids is not None else []
    out = []
    for k in kids:
        if isinstance(k, pikepdf.Dictionary) and "/S" in k:
            out.append(k)
            out += _elements(k)
    return out


def test_the_combined_pdf_keeps_each_part_s_tags(parts, tmp_path):
    """One structure tree with each part's document element, pointing at the part's own pages; the
    parent tree's keys unique and each page's /StructParents one of them; the language and /MarkInfo;
    the table header cells' ids unique and named by the data cells' /Headers; the PDF version the
    parts declare (1.7, the base of PDF/UA-1)."""
    engine.concatenate_pdfs(tmp_path / "all.pdf", parts, "All", "MEG373")
    with pikepdf.Pdf.open(parts[0]) as part:
        version = part.pdf_version
    with pikepdf.Pdf.open(tmp_path / "all.pdf") as pdf:
        assert pdf.pdf_version == version == "1.7"
        root = pdf.Root
        assert str(root.Lang) == "en"
        assert bool(root.MarkInfo.Marked) is True
        tree = root.StructTreeRoot
        assert len(tree.K) == 3
        pages = {p.obj.objgen: i for i, p in enumerate(pdf.pages)}
        for part, (first, last) in zip(tree.K, ((0, 2), (4, 5), (6, 6)), strict=True):
            assert part.P.objgen == tree.objgen
            on = {pages[e.Pg.objgen] for e in _elements(part) if "/Pg" in e}
            assert on and min(on) >= first and max(on) <= last
        nums = list(tree.ParentTree.Nums)
        keys = [int(k) for k in nums[::2]]
        assert len(keys) == len(set(keys)) and int(tree.ParentTreeNextKey) > max(keys)
        marked = [int(p.obj.StructParents) for p in pdf.pages if "/StructParents" in p.obj]
        assert len(marked) == 6 and set(marked) <= set(keys)
        ids = [bytes(x) for x in list(tree.IDTree.Names)[::2]]
        assert len(ids) == len(set(ids)) >= 3
        headers = {bytes(h) for part in tree.K for e in _elements(part) if "/A" in e
                   for a in (e.A if isinstance(e.A, pikepdf.Array) else [e.A])
                   if isinstance(a, pikepdf.Dictionary) and "/Headers" in a for h in a.Headers}
        assert headers and headers <= set(ids)
