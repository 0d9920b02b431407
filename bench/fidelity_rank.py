"""Does the cut's estimated error rank the cuts like their PSNR? Over the volume cases of
bench/fidelity_bench.sh whose rows in bench/results/fidelity.json carry the tag RANK_TAG (default
"capped") and the estimate the render reported (cut_estimated_error, recorded by the bench),
Spearman's rank correlation of estimate against PSNR: over all distinct cuts, per budget across
cases, and per case (-1: a perfect ranking). Writes bench/results/fidelity_rank.json.
usage: RANK_TAG=capped /usr/bin/python3 bench/fidelity_rank.py   (needs numpy; run after the bench)
RANK_TAG may list tags, "auto,r0.5": each case takes the first of them it has rows of, unless
RANK_TAG_FOR ("bracket-inside=r0.5,...") names its tag (the defaults, when they differ by
mesh); RANK_CASES (a comma list) keeps those cases only, RANK_OUT
names the output (default bench/results/fidelity_rank.json); RANK_FLOAT=1 ranks by the PSNR of the
integrator's unrounded colours (cut_db_float, rows from tag float32 on) instead of the 8-bit one."""
import json, os
import numpy as np
from fidelity_rows import choose_tags, volume_cases
os.chdir(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))
tag = os.environ.get('RANK_TAG', 'capped')
tags = tag.split(',')
only = set(filter(None, os.environ.get('RANK_CASES', '').split(',')))
out = os.environ.get('RANK_OUT', 'bench/results/fidelity_rank.json')
db = 'cut_db_float' if os.environ.get('RANK_FLOAT') == '1' else 'cut_db'
volume = volume_cases()
every = [r for r in json.load(open('bench/results/fidelity.json'))['runs']
         if r['tag'] in tags and r['case'] in volume and (not only or r['case'] in only) and r.get('cut_estimated_error') is not None and r.get(db) is not None]
given = dict(kv.split('=', 1) for kv in filter(None, os.environ.get('RANK_TAG_FOR', '').split(',')))
chosen = choose_tags(every, tags, given)
rows = [r for r in every if r['tag'] == chosen[r['case']]]
seen, cuts = set(), []
for r in rows:  # a budget below the coarsest level gives the same cut: counted once
    if (r['case'], r['cut_tets']) not in seen:
        seen.add((r['case'], r['cut_tets']))
        cuts.append(dict(case=r['case'], tag=r['tag'], budget=r['budget'], cut_tets=r['cut_tets'], est=r['cut_estimated_error'], cut_db=r[db]))
def spearman(a, b):
    ra, rb = np.argsort(np.argsort(a)), np.argsort(np.argsort(b))
    return float(np.corrcoef(ra, rb)[0, 1])
result = {"note": f"the cut's estimated error against its PSNR (tag {tag}{', per case ' + str(given) if given else ''}, the estimate recorded by fidelity_bench.sh); identical cuts counted once; deterministic, one run",
          "tag": tag, "psnr": db, "cuts": len(cuts), "spearman_all": spearman([r['est'] for r in cuts], [r['cut_db'] for r in cuts]), "per_budget": {}, "per_case": {}, "rows": cuts}
for b in ['coarsest', '5', '10', '25', '50']:
    s = [r for r in cuts if r['budget'] == b]
    if len(s) > 2: result["per_budget"][b] = spearman([r['est'] for r in s], [r['cut_db'] for r in s])
for c in sorted({r['case'] for r in cuts}):
    s = [r for r in cuts if r['case'] == c]
    if len(s) > 1: result["per_case"][c] = spearman([r['est'] for r in s], [r['cut_db'] for r in s])
json.dump(result, open(out, 'w'), indent=1)
print(json.dumps({k: v for k, v in result.items() if k != 'rows'}, indent=1))
