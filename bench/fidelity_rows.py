"""What bench/fidelity_rank.py and bench/fidelity_summary.py share about the rows of
bench/results/fidelity.json: which cases are volume cases (mode dvr in fidelity_bench.sh's case
list) and which tag each case takes when several are given."""
import os
import re

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")


def volume_cases():
    text = open(os.path.join(ROOT, "bench/fidelity_bench.sh")).read()
    return {m.group(1) for m in re.finditer(r'^  "([^"|]+)\|[^|]+\|[^|]+\|dvr\|', text, re.M)}


def choose_tags(rows, tags, given):
    """Per case of `rows`: the tag `given` names for it, else the first of `tags` it has rows of."""
    out = {}
    for case in {r["case"] for r in rows}:
        out[case] = given.get(case) or next((t for t in tags if any(r["case"] == case and r["tag"] == t for r in rows)), None)
    return out
