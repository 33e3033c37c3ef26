"""The suite's mutation score, from a finished ``mutmut run``.

mutmut (configured in ``pyproject.toml``) plants one small change at a time in the
core modules and runs the tests that reach the changed function; a mutant is
*killed* when a test fails, *survives* when none does. Some mutants cannot be
killed because they do not change what the code computes (``np.einsum("nij")``
against ``"NIJ"``, a default that no caller uses): ``docs/mutation_equivalents.txt``
lists those by name (``fnmatch`` patterns allowed), each with its reason. The score
is killed / (all − equivalent); a timeout or a crash counts as killed, as mutmut
counts it, and a mutant no test reaches counts as surviving.

Of ``formulations.py`` only Newton's start and the pressure rows' scale are in
scope (:data:`FORMULATIONS_SCOPE`); mutmut mutates the whole file, so run those
methods by name (``mutmut run "fe_mpm.formulations.xǁGridFieldsǁstart_from_rest__mutmut_*"``)
and the others are left out of the count. (Until the redesign these were methods of
``Simulation``, as was the point update, now ``point_update.py``.)

Usage: ``mutmut run`` then ``./run python benchmarks/mutation_score.py [--survivors]``
from the repository root (``--dir`` where ``mutants/`` lies elsewhere; several
folders merge, a later folder's result replacing an earlier one's). Not a test.
"""

from __future__ import annotations

import argparse
import fnmatch
import json
from collections import Counter, defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: mutmut's exit codes (mutmut/stats.py) by the outcome counted here.
KILLED = {1, 3, 36, -24, 24, 152, 255, -11, -9, 37}
SURVIVED = {0}
NO_TESTS = {5, 33}

#: The methods of ``GridFields`` in scope: the projected pressure and the pressure scale.
FORMULATIONS_SCOPE = ("start_from_rest", "pressure_volume")


#: Of ``step_forms.py`` only the update vector's layout is in scope (the point update);
#: ``StepForms`` builds the forms, whose mathematics ``forms/`` holds and is in scope.
STEP_FORMS_SCOPE = ("ǁUpdateLayoutǁ",)


def in_scope(name: str) -> bool:
    """False for the mutants outside the scope: see the two scope tuples above."""
    if name.startswith("fe_mpm.step_forms."):
        return any(part in name for part in STEP_FORMS_SCOPE)
    if not name.startswith("fe_mpm.formulations."):
        return True
    return any(f"ǁGridFieldsǁ{method}__mutmut_" in name for method in FORMULATIONS_SCOPE)


def equivalents(path: Path) -> list[tuple[str, str]]:
    """The (pattern, reason) pairs of the equivalents file; ``#`` starts the reason."""
    pairs = []
    for line in path.read_text().splitlines():
        pattern, _, reason = line.partition("#")
        if pattern.strip():
            pairs.append((pattern.strip(), reason.strip()))
    return pairs


def outcomes(folders: list[Path]) -> dict[str, int | None]:
    """Exit code by mutant name, over every ``.meta`` file under each ``folder/mutants``.

    The last folder must hold the current code. An earlier folder's result counts
    only where its function is unchanged (the same hash in mutmut's ``.meta``): a
    change renumbers a function's mutants. A later result replaces an earlier one;
    a mutant a folder did not run (None) keeps the earlier result.
    """

    def read(folder: Path) -> dict[str, tuple[int | None, str | None]]:
        found = {}
        for meta in (folder / "mutants").rglob("*.meta"):
            data = json.loads(meta.read_text())
            for name, code in data["exit_code_by_key"].items():
                function = name.rsplit(".", 1)[1].split("__mutmut_")[0]
                found[name] = (code, data["hash_by_function_name"].get(function))
        return found

    current = read(folders[-1])
    codes: dict[str, int | None] = {}
    for folder in folders[:-1]:
        for name, (code, digest) in read(folder).items():
            if code is not None and name in current and digest == current[name][1]:
                codes[name] = code
    for name, (code, _) in current.items():
        if code is not None or name not in codes:
            codes[name] = code
    return {name: code for name, code in codes.items() if in_scope(name)}


def main() -> None:
    """Print the score per module and in all."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--dir", type=Path, nargs="+", default=[ROOT], help="folders holding mutants/, oldest first"
    )
    p.add_argument("--equivalents", type=Path, default=ROOT / "docs/mutation_equivalents.txt")
    p.add_argument("--survivors", action="store_true", help="list the surviving mutants")
    args = p.parse_args()
    patterns = equivalents(args.equivalents)
    codes = outcomes(args.dir)
    if not codes:
        where = ", ".join(str(d / "mutants") for d in args.dir)
        raise SystemExit(
            f"no mutmut results under {where}: run `mutmut run` there first "
            "(see docs/verification.md)"
        )
    counts: dict[str, Counter] = defaultdict(Counter)
    survivors, unused = [], {pattern for pattern, _ in patterns}
    for name, code in sorted(codes.items()):
        module = name.rsplit(".", 1)[0]
        matched = [pat for pat, _ in patterns if fnmatch.fnmatchcase(name, pat)]
        unused -= set(matched)
        if code is None:
            outcome = "not run"
        elif matched:
            outcome = "equivalent"
        elif code in KILLED:
            outcome = "killed"
        elif code in SURVIVED or code in NO_TESTS:
            outcome = "survived" if code in SURVIVED else "no tests"
            survivors.append(name)
        else:
            outcome = "other"
        counts[module][outcome] += 1
    columns = ("killed", "survived", "no tests", "equivalent", "not run", "other")
    print(f"{'module':<42}" + "".join(f"{c:>11}" for c in columns) + f"{'score':>8}")
    total = Counter()
    for module, c in sorted(counts.items()):
        total += c
        print(f"{module:<42}" + "".join(f"{c[k]:>11}" for k in columns) + _score(c))
    print(f"{'all':<42}" + "".join(f"{total[k]:>11}" for k in columns) + _score(total))
    if unused:
        print("patterns in the equivalents file that match no mutant:", sorted(unused))
    if args.survivors:
        print("\n".join(survivors))


def _score(c: Counter) -> str:
    run = c["killed"] + c["survived"] + c["no tests"]
    return f"{100 * c['killed'] / run:>7.1f}%" if run else f"{'-':>8}"


if __name__ == "__main__":
    main()
