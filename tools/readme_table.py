"""The README's "which model for which job" table, from the report's CSV (docs/report.csv): the one owner of it.

    python tools/readme_table.py            # print the table
    python tools/readme_table.py --write    # put it into README.md, between its markers
    python tools/readme_table.py --check    # exit 1 where README.md's table is not what the report gives

Run it (with --write) after ``fitlab report --out docs``; tests/test_readme.py checks that README.md holds what
it prints.  The table is the report's recommendation per job (fitlab.report.pareto.recommend), rendered by
tools/site/figures.py, which renders it on the site too.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools" / "site"))

from figures import use_table  # noqa: E402

README = ROOT / "README.md"
BEGIN = "<!-- which-model table: written by tools/readme_table.py from docs/report.csv; do not edit -->"
END = "<!-- end of the which-model table -->"


def with_table(text: str, table: str) -> str:
    """``text`` with the table between its markers replaced by ``table``."""
    if text.count(BEGIN) != 1 or text.count(END) != 1 or text.index(BEGIN) > text.index(END):
        raise SystemExit(f"{README.name}: the table's markers are missing or out of order ({BEGIN!r} ... {END!r})")
    head, rest = text.split(BEGIN)
    _, tail = rest.split(END)
    return f"{head}{BEGIN}\n{table}\n{END}{tail}"


def main(argv: list[str]) -> int:
    table = use_table()
    if not argv:
        print(table)
        return 0
    text = README.read_text()
    new = with_table(text, table)
    if argv == ["--check"]:
        if new != text:
            print("README.md's table is not the report's: run python tools/readme_table.py --write", file=sys.stderr)
            return 1
        return 0
    if argv == ["--write"]:
        README.write_text(new)
        return 0
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
