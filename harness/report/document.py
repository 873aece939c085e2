"""The report's document: Markdown and HTML side by side, tables exported as CSV and
LaTeX, figures as PNG and SVG, and the number formats they share."""

from __future__ import annotations

import base64
import html
import math
import re
import unicodedata
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

__all__ = [
    "Document",
    "cell",
    "fmt_time",
    "latex_table",
    "markdown_table",
    "pyplot",
    "shorten",
    "slug",
    "span",
]


def cell(v: Any) -> str:
    if v is None:
        return "–"
    if isinstance(v, bool | np.bool_):
        return "yes" if v else "no"
    if isinstance(v, int | np.integer):
        return str(int(v))
    if isinstance(v, float | np.floating):
        v = float(v)
        if math.isnan(v):
            return "–"
        if math.isinf(v):
            return "∞" if v > 0 else "-∞"
        if v != 0 and (abs(v) >= 1e9 or abs(v) < 1e-3):
            return f"{v:.3g}"
        # whole: ":.4g" wrote 19970 as 1.997e+04 beside 394 in a column, and counts to
        # 10^9 read as counts (569019 beside 19968); from 9999.5, which ":.4g" rounds up
        if abs(v) >= 9999.5:
            return f"{v:.0f}"
        return f"{v:.4g}"
    return str(v)


def markdown_table(df: pd.DataFrame) -> str:
    cols = list(df.columns)
    lines = [
        "| " + " | ".join(map(str, cols)) + " |",
        "| " + " | ".join("---" for _ in cols) + " |",
    ]
    for row in df.itertuples(index=False):
        lines.append("| " + " | ".join(cell(v).replace("|", "\\|") for v in row) + " |")
    return "\n".join(lines)


_TEX = {
    "\\": r"\textbackslash{}",
    "&": r"\&",
    "%": r"\%",
    "$": r"\$",
    "#": r"\#",
    "_": r"\_",
    "{": r"\{",
    "}": r"\}",
    "~": r"\textasciitilde{}",
    "^": r"\textasciicircum{}",
    "×": r"$\times$",
    "µ": r"$\mu$",
    "δ": r"$\delta$",
    "±": r"$\pm$",
    "–": "--",
    "∞": r"$\infty$",
    "≥": r"$\geq$",
    "≤": r"$\leq$",
    "·": r"$\cdot$",
    "°": r"$^\circ$",
    "…": r"\ldots{}",
    "—": "---",
    "−": "$-$",
    "→": r"$\rightarrow$",
    "≈": r"$\approx$",
    "|": "$|$",
    "<": "$<$",
    ">": "$>$",
}
_GREEK_CAPITALS = {
    "GAMMA",
    "DELTA",
    "THETA",
    "LAMBDA",
    "XI",
    "PI",
    "SIGMA",
    "UPSILON",
    "PHI",
    "PSI",
    "OMEGA",
}
"""Capital Greek letters that LaTeX names (the others look like Latin ones)."""
_SUPERSCRIPTS = dict(zip("⁰¹²³⁴⁵⁶⁷⁸⁹⁻", "0123456789-", strict=True))


_ACCENTS = {"\u0301": "'", "\u0300": "`", "\u0302": "^", "\u0308": '"', "\u0303": "~",
            "\u0327": "c", "\u030a": "r", "\u030c": "v"}  # fmt: skip
"""Combining marks as LaTeX accent commands (é is \\'{e}: a user's path may have one)."""


def _tex(s: str) -> str:
    """`s` as LaTeX that compiles with any input encoding: specials escaped, every other
    character ASCII (a Greek letter as its math command, a run of superscripts raised as
    one, an accented Latin letter with its accent command, any other character as its
    code point)."""
    parts = re.split(f"([{''.join(_SUPERSCRIPTS)}]+)", s)  # (odd parts: superscript runs)
    out = "".join(
        "$^{" + "".join(_SUPERSCRIPTS[c] for c in part) + "}$"
        if i % 2
        else "".join(_tex_char(c) for c in part)
        for i, part in enumerate(parts)
    )
    # a number keeps its unit on its line (a review: "12–12.2 / µs" in a wrapped column)
    return _UNIT_SPACE.sub("~", out)


_UNIT_SPACE = re.compile(r"(?<=\d) (?=(?:\$\\mu\$s|ms|s|mm|m|\\%|\$\\times\$)(?![A-Za-z]))")
"""A space between a digit and a unit in escaped LaTeX (µs is $\\mu$s by then)."""


def _tex_char(c: str) -> str:
    if c in _TEX:
        return _TEX[c]
    if c.isascii():
        return c
    base, *marks = unicodedata.normalize("NFD", c)
    if base.isascii() and base.isalpha() and len(marks) == 1 and marks[0] in _ACCENTS:
        return f"\\{_ACCENTS[marks[0]]}{{{base}}}"
    name = unicodedata.name(c, "").replace("LAMDA", "LAMBDA").split()
    if name[:2] == ["GREEK", "SMALL"] and len(name) == 4 and name[3] != "OMICRON":
        return f"$\\{name[3].lower()}$"
    if name[:2] == ["GREEK", "CAPITAL"] and len(name) == 4 and name[3] in _GREEK_CAPITALS:
        return f"$\\{name[3].capitalize()}$"
    return f"[U+{ord(c):04X}]"


LATEX_LINE_PT = 345.0
r"""\linewidth of a one-column article at 10 pt: a table estimated wider is fitted to it."""
LATEX_PAGE_PT = 550.0
r"""\textheight of that article: the height of an upright table, the line of one set
sideways."""
LATEX_FONTS = (("small", 4.6, 11.0), ("footnotesize", 4.3, 9.5), ("scriptsize", 4.0, 8.0))
"""Font sizes a table may be set in: (LaTeX name, estimated width of a character (an
average of digits and lower case in Computer Modern, whose smaller sizes are drawn
wider: cmr7's digits are 4.0 pt), line height), in pt. A float is set \\small; a long
table takes the largest in which it fits the line."""
LATEX_COLUMN_PT = 12.0
"""Space between two columns (2 \\tabcolsep)."""
LATEX_WRAP_CHARS = 12
"""A column is not wrapped narrower than this many characters (nor than its longest word)."""
LATEX_MIN_SCALE = 0.8
"""A table is scaled down to its line by no more than this; a wider one is set sideways
(a page of its own)."""


def _column_widths(head: list[str], body: list[list[str]], numeric: list[bool]) -> tuple:
    """(natural, narrowest, hardest) width of each column in characters: a number never
    wraps, a header or a text cell may, at its spaces, down to its longest word and to
    :data:`LATEX_WRAP_CHARS` (where it is that wide), or, where nothing else fits, to its
    longest word alone."""

    def word(x: str) -> int:
        return max((len(w) for w in x.split()), default=0)

    natural, floor, hard = [], [], []
    for j, h in enumerate(head):
        vals = [row[j] for row in body]
        longest = max((len(v) for v in vals), default=0)
        natural.append(max(longest, len(h)))
        words = max([word(h), *(longest if numeric[j] else word(v) for v in vals)], default=0)
        floor.append(max(words, min(natural[-1], LATEX_WRAP_CHARS)))
        hard.append(words)
    return natural, floor, hard


def _total(w: list[int], char: float = LATEX_FONTS[0][1], gap: float = LATEX_COLUMN_PT) -> float:
    return char * sum(w) + gap * len(w)


def _fit(
    natural: list[int],
    floor: list[int],
    line: float = LATEX_LINE_PT,
    char: float = LATEX_FONTS[0][1],
    gap: float = LATEX_COLUMN_PT,
) -> list[int]:
    """Column widths (characters) that fit `line` (pt) where they can: each column
    narrowed in proportion to its natural width (so that its cells wrap to about as many
    lines as the others': one cap for all gave a 250-character column 16 lines a row),
    not below its floor; the floors where they do not fit."""

    def scaled(s: float) -> list[int]:
        return [max(f, min(n, math.ceil(s * n))) for n, f in zip(natural, floor, strict=True)]

    if _total(natural, char, gap) <= line:
        return natural
    if _total(floor, char, gap) > line:
        return floor
    lo, hi = 0.0, 1.0  # (scaled(lo) is the floors: they fit; scaled(hi) does not)
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _total(scaled(mid), char, gap) <= line else (lo, mid)
    return scaled(lo)


def _rows_height(rows: list[list[str]], widths: list[int], font: tuple) -> float:
    """Estimated height (pt) of table rows: each as many lines as its most wrapped cell
    (words do not fill a line: a fifth more), plus the rules."""

    def lines(row: list[str]) -> int:
        return max(
            (
                1 if len(c) <= w else math.ceil(1.2 * len(c) / max(w, 1))
                for c, w in zip(row, widths, strict=True)
            ),
            default=1,
        )

    return font[2] * sum(max(1, lines(r)) for r in rows) + 20.0


def latex_table(df: pd.DataFrame, caption: str) -> str:
    """A booktabs table of `df` (no pandas/jinja2 needed), laid out for a one-column
    article from estimated widths (:data:`LATEX_FONTS`, :data:`LATEX_COLUMN_PT` between
    columns):

    - a table wider than the line wraps its columns, each in proportion to its width
      (paragraph columns: text ragged right, numbers ragged left; headers wrap too);
    - a float (\\small) still wider at its narrowest is scaled down to the line
      (graphicx's ``\\resizebox``, never enlarging: every float has it, since the
      estimate can be short) by at most :data:`LATEX_MIN_SCALE`, else set sideways
      (rotating's ``sidewaystable``, the text height its line) and fitted to that;
    - a table taller than its page is a ``longtable`` (its header repeated on each page),
      upright where it fits the line, else on landscape pages (pdflscape), in the largest
      of the sizes that fits.

    Scaling alone had set the headline's table, one of whose columns runs to 250
    characters, in 1.3 pt type, and tables of many numeric columns in 3-5 pt.

    Raises:
        TypeError: `df` not a DataFrame, `caption` not a string.
    """
    if not isinstance(df, pd.DataFrame):
        raise TypeError(f"Expected `df` to be a pandas DataFrame, got {type(df).__name__}.")
    if not isinstance(caption, str):
        raise TypeError(f"Expected `caption` to be a string, got {type(caption).__name__}.")
    numeric = [pd.api.types.is_numeric_dtype(df[c]) for c in df.columns]
    head = [str(c) for c in df.columns]
    body = [[cell(v) for v in row] for row in df.itertuples(index=False)]
    caption = " ".join(caption.split())  # (a blank line ends \caption's argument: an error)
    if not head:  # (no column: nothing to lay out)
        head, body, numeric = [""], [[""] for _ in body], [False]
    natural, floor, hard = _column_widths(head, body, numeric)
    small = LATEX_FONTS[0]
    caption_pt = small[2] * math.ceil(1.15 * len(caption) * small[1] / LATEX_LINE_PT) + 10.0

    def layout(line: float, font: tuple) -> tuple[list[int], float]:
        w = _fit(natural, floor, line, font[1])
        return w, min(1.0, line / max(_total(w, font[1]), 1e-9))

    widths, scale = layout(LATEX_LINE_PT, small)
    sideways = scale < LATEX_MIN_SCALE
    if sideways:
        widths, scale = layout(LATEX_PAGE_PT, small)
    room = LATEX_LINE_PT if sideways else LATEX_PAGE_PT  # (the height its page gives it)
    long = scale * _rows_height([head, *body], widths, small) + caption_pt > room
    font, landscape = small, False
    gap = LATEX_COLUMN_PT
    # a long table, or one that even sideways would shrink below LATEX_MIN_SCALE (a
    # review: 40 text columns in 1.9 pt type): the first of these in which it fits its
    # line; a short one that fits none stays a sideways float, shrunk (a last resort)
    if long or scale < LATEX_MIN_SCALE:
        tries = [(False, f, floor, gap) for f in LATEX_FONTS[:2]]
        tries += [
            (True, f, low, g) for g in (gap, gap / 2) for low in (floor, hard) for f in LATEX_FONTS
        ]
        for landscape, font, low, gap in tries:
            line = LATEX_PAGE_PT if landscape else LATEX_LINE_PT
            trial = _fit(natural, low, line, font[1], gap)
            if _total(trial, font[1], gap) <= line:
                widths, long, sideways = trial, True, False
                break
        else:
            if long:
                widths, sideways = trial, False
            else:
                font, landscape, gap = small, False, LATEX_COLUMN_PT
    wrapped = [w < n for w, n in zip(widths, natural, strict=True)]
    align = "".join(
        (
            (r">{\raggedleft\arraybackslash}" if num else r">{\raggedright\arraybackslash}")
            + f"p{{{font[1] * w:.1f}pt}}"
        )
        if wrap
        else ("r" if num else "l")
        for w, wrap, num in zip(widths, wrapped, numeric, strict=True)
    )
    needs = (
        ["booktabs"]
        + (["array"] if any(wrapped) else [])
        + (["longtable"] + (["pdflscape"] if landscape else []) if long else ["graphicx"])
        + (["rotating"] if sideways else [])
    )
    # (each row opens with {}: after \\ or a rule, a row starting with '[' was read as an
    # optional argument, and one starting with '*' lost it)
    header = [r"\toprule", "{}" + " & ".join(_tex(c) for c in head) + r" \\", r"\midrule"]
    rows = ["{}" + " & ".join(_tex(v) for v in row) + r" \\" for row in body]
    first = "% rsmbench table: needs " + ", ".join(f"\\usepackage{{{x}}}" for x in needs)
    if long:
        where = "on landscape pages" if landscape else "upright"
        return (
            "\n".join(
                [
                    first + f" (a long table, {where}: it breaks across pages)",
                    *([r"\begin{landscape}"] if landscape else []),
                    rf"{{\{font[0]}"
                    + (
                        ""
                        if gap == LATEX_COLUMN_PT
                        else rf"\setlength{{\tabcolsep}}{{{gap / 2:g}pt}}"
                    ),
                    rf"\begin{{longtable}}{{{align}}}",
                    rf"\caption{{{_tex(caption)}}} \\",
                    *header,
                    r"\endfirsthead",
                    rf"\multicolumn{{{len(head)}}}{{l}}{{\emph{{(continued)}}}} \\",
                    *header,
                    r"\endhead",
                    r"\bottomrule",
                    r"\endlastfoot",
                    *rows,
                    r"\end{longtable}}",
                    *([r"\end{landscape}"] if landscape else []),
                ]
            )
            + "\n"
        )
    env = "sidewaystable" if sideways else "table"
    return (
        "\n".join(
            [
                first + (" (set sideways)" if sideways else ""),
                rf"\begin{{{env}}}" + ("" if sideways else "[htbp]"),
                r"\centering\small",
                # (shrinks a table wider than the line, never enlarges one)
                r"\resizebox{\ifdim\width>\linewidth\linewidth\else\width\fi}{!}{%",
                rf"\begin{{tabular}}{{{align}}}",
                *header,
                *rows,
                r"\bottomrule",
                r"\end{tabular}}",
                rf"\caption{{{_tex(caption)}}}",
                rf"\end{{{env}}}",
            ]
        )
        + "\n"
    )


def slug(text: str, limit: int = 40) -> str:
    """A file name from `text`: lower-case words joined by '_', whole words only, at most
    `limit` characters (a first word longer than that is kept whole)."""
    words = re.sub(r"[^a-z0-9]+", " ", text.lower()).split()
    out: list[str] = []
    for w in words:
        if out and len("_".join([*out, w])) > limit:
            break
        out.append(w)
    return "_".join(out) or "table"


def shorten(text: str, limit: int) -> str:
    """`text` whole if it fits in `limit` characters, else cut at the last word boundary
    before the limit, with '…' (never mid-word)."""
    text = " ".join(str(text).split())
    if len(text) <= limit:
        return text
    head = text[: limit - 1]
    if " " not in head:  # one word longer than the limit: keep it whole
        return text.split(" ", 1)[0] + "…"
    if text[limit - 1] != " ":  # (head ends inside a word: drop it)
        head = head.rsplit(" ", 1)[0]
    return head.rstrip(" ,;:(") + "…"


def span(lo: float, hi: float) -> str:
    """``lo–hi`` in the unit that suits `hi` (s, ms or µs)."""
    if not (np.isfinite(lo) and np.isfinite(hi)):
        return "–"
    unit, scale = ("s", 1.0) if hi >= 1 else ("ms", 1e3) if hi >= 1e-3 else ("µs", 1e6)
    return f"{lo * scale:.3g}–{hi * scale:.3g} {unit}"


def fmt_time(seconds: float) -> str:
    if not np.isfinite(seconds):
        return "–"
    a = abs(seconds)
    if a >= 1:
        return f"{seconds:.3g} s"
    if a >= 1e-3:
        return f"{seconds * 1e3:.3g} ms"
    return f"{seconds * 1e6:.3g} µs"


class Document:
    """Collects Markdown and HTML side by side, and exports tables and figures."""

    def __init__(self, out: Path):
        self.folder = out
        self.md: list[str] = []
        self.html: list[str] = []
        self.figs = out / "figures"
        self.tabs = out / "tables"
        self.names: set[str] = set()
        for d in (self.figs, self.tabs):
            d.mkdir(parents=True, exist_ok=True)

    def _unique(self, name: str) -> str:
        base, k = name, 2
        while name in self.names:
            name, k = f"{base}_{k}", k + 1
        self.names.add(name)
        return name

    def h(self, text: str, level: int = 2) -> None:
        self.md.append(f"{'#' * level} {text}\n")
        self.html.append(f"<h{level}>{html.escape(text)}</h{level}>")

    def p(self, text: str) -> None:
        self.md.append(text + "\n")
        self.html.append(f"<p>{html.escape(text)}</p>")

    def bullets(self, items: list[str]) -> None:
        self.md.append("\n".join(f"- {t}" for t in items) + "\n")
        self.html.append("<ul>" + "".join(f"<li>{html.escape(t)}</li>" for t in items) + "</ul>")

    def table(
        self,
        df: pd.DataFrame,
        caption: str,
        name: str | None = None,
        *,
        data: pd.DataFrame | None = None,
    ) -> None:
        """Add a table: `df` as the reader sees it (Markdown, HTML and ``tables/NAME.tex``,
        cells formatted), `data` as ``tables/NAME.csv`` (NAME from the caption when not
        given).

        Args:
            df: the displayed table; its cells may be formatted text ("0/18", "3.5 ms").
            caption: the table's caption.
            name: the file name's stem (default: from the caption).
            data: the same figures for machines: numbers in numeric columns whose
                snake_case names carry their units (``cpu_ms_median``), a count "a/b" as
                two columns, a missing value NaN (an empty cell), text columns (methods,
                scenes, verdicts) as text. Its rows need not be `df`'s (a method × class
                grid can be written one row per cell). Default: `df` itself, for a table
                whose cells are already such numbers and text.

        Raises:
            ValueError: a CSV column name is not snake_case.
        """
        for arg, v in (("df", df), ("data", data)):
            if not (v is None and arg == "data") and not isinstance(v, pd.DataFrame):
                raise TypeError(
                    f"Expected `{arg}` to be a pandas DataFrame, got {type(v).__name__}."
                )
        csv = (df if data is None else data).reset_index(drop=True)
        bad = [c for c in csv.columns if not re.fullmatch(r"[a-z][a-z0-9_]*", str(c))]
        twice = sorted({str(c) for c in csv.columns[csv.columns.duplicated()]})
        if bad or twice:
            raise ValueError(
                f"Expected the CSV columns of table {caption[:40]!r} (`data`, or `df` without"
                f" it) to be distinct snake_case names with units, got"
                + (f" {bad}" if bad else "")
                + (f" {twice} more than once" if twice else "")
                + "."
            )
        name = self._unique("table:" + slug(name or caption)).split(":", 1)[1]
        df = df.reset_index(drop=True)
        csv.to_csv(self.tabs / f"{name}.csv", index=False)
        (self.tabs / f"{name}.tex").write_text(latex_table(df, caption))
        self.md.append(
            markdown_table(df) + f"\n\n*{caption}* (tables/{name}.csv, tables/{name}.tex)\n"
        )
        cells = "".join(
            "<tr>" + "".join(f"<td>{html.escape(cell(v))}</td>" for v in row) + "</tr>"
            for row in df.itertuples(index=False)
        )
        head = "".join(f"<th>{html.escape(str(c))}</th>" for c in df.columns)
        self.html.append(
            f"<table><thead><tr>{head}</tr></thead><tbody>{cells}</tbody></table>"
            f"<p><em>{html.escape(caption)}</em> (<a href='tables/{name}.csv'>CSV</a>,"
            f" <a href='tables/{name}.tex'>LaTeX</a>)</p>"
        )

    def figure(self, fig, name: str, caption: str) -> None:
        import matplotlib.pyplot as plt

        name = self._unique("figure:" + name).split(":", 1)[1]
        png = self.figs / f"{name}.png"
        fig.savefig(png, dpi=130, bbox_inches="tight")
        fig.savefig(self.figs / f"{name}.svg", bbox_inches="tight", metadata={"Date": None})
        plt.close(fig)
        self.image(png, caption, svg=True)

    def image(self, path: Path, caption: str, svg: bool = False) -> None:
        rel = path.relative_to(self.folder)
        extra = f" (vector: {rel.with_suffix('.svg')})" if svg else ""
        self.md.append(f"![{caption}]({rel})\n\n*{caption}*{extra}\n")
        data = base64.b64encode(path.read_bytes()).decode()
        link = f" <a href='{rel.with_suffix('.svg')}'>SVG</a>" if svg else ""
        self.html.append(
            f'<figure><img src="data:image/png;base64,{data}" style="max-width:100%">'
            f"<figcaption>{html.escape(caption)}{link}</figcaption></figure>"
        )


def pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"svg.fonttype": "none", "svg.hashsalt": "rsmbench", "font.size": 9})
    return plt
