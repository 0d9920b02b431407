"""Does the cut's estimated error rank the cuts like their PSNR? For every volume case of
bench/fidelity_bench.sh with rows tagged common-error in bench/results/fidelity.json, the same
cut is rendered again (same store, camera, TF, size and budget) for its estimated error
(render --json cut_estimated_error), then Spearman's rank correlation of estimate against PSNR
over all distinct cuts, per budget across cases, and per case. Writes
bench/results/fidelity_rank.json. Run after bench/fidelity_bench.sh (it reuses its stores).
usage: /usr/bin/python3 bench/fidelity_rank.py   (needs numpy)"""
import json, re, subprocess, os, sys
os.chdir(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))
os.makedirs('bench/out/rank', exist_ok=True)
bin='build/release/apps/tetrascope'
data='../shared/data'
src=open('bench/fidelity_bench.sh').read()
cases={}
for m in re.finditer(r'^  "([^"|]+)\|([^|]+)\|([^|]+)\|([^|]+)\|([^|]+)\|(.*)"$', src, re.M):
    name, mesh, cam, mode, unit, tf = m.groups()
    cases[name]=(mesh.replace('$data', data), cam, mode, unit, tf.replace('\\"','"'))
fid=json.load(open('bench/results/fidelity.json'))
rows=[r for r in fid['runs'] if r['tag']=='common-error' and r['case'] in cases and cases[r['case']][2]=='dvr']
out=[]
stores={}
for name in sorted({r['case'] for r in rows}):
    mesh, cam, mode, unit, tf = cases[name]
    if not os.path.exists(mesh): continue
    base=os.path.basename(mesh)[:-4]
    store=f'bench/out/fidelity/{base}-common-error.store'
    if not os.path.isdir(store):
        subprocess.run([bin,'preprocess',mesh,'-o',store,'--progress','none'],check=True,stdout=subprocess.DEVNULL)
    tfp=f'bench/out/rank/{name}.tf.json'
    if tf: open(tfp,'w').write(tf)
    else:
        info=json.loads(subprocess.run([bin,'info','--json',mesh],capture_output=True,text=True).stdout); a=info['attributes'][0]
        json.dump({"attribute":a["name"],"colormap":"viridis","opacity":[[a["min"],0],[a["max"],0.3]]}, open(tfp,'w'))
    for r in [x for x in rows if x['case']==name]:
        args=[bin,'render',store,'-o','bench/out/rank/x.png','--camera',cam,'--size','256x192','--tf',tfp,'--budget',str(r['cut_tets'] if r['budget']=='coarsest' else r['input_tets']*int(r['budget'])//100),'--json']
        if unit!='0': args+=['--unit-distance',unit]
        j=json.loads(subprocess.run(args,capture_output=True,text=True,check=True).stdout.strip().splitlines()[-1])
        out.append(dict(case=name,budget=r['budget'],cut_tets=r['cut_tets'],render_tets=j['tets'],est=j.get('cut_estimated_error'),cut_db=r['cut_db']))
        print(out[-1], flush=True)
import numpy as np
fid_rows = json.load(open('bench/results/fidelity.json'))['runs']
rendered = {o['case'] for o in out}
for r in fid_rows:  # cases measured with the estimate recorded (the blades)
    if r['tag'] == 'common-error' and r.get('cut_estimated_error') is not None and r['case'] not in rendered:
        out.append(dict(case=r['case'], budget=r['budget'], cut_tets=r['cut_tets'], render_tets=r['cut_tets'], est=r['cut_estimated_error'], cut_db=r['cut_db']))
seen, cuts = set(), []
for r in out:  # a budget below the coarsest level gives the same cut: counted once
    if (r['case'], r['cut_tets']) not in seen:
        seen.add((r['case'], r['cut_tets']))
        cuts.append(r)
def spearman(a, b):
    ra, rb = np.argsort(np.argsort(a)), np.argsort(np.argsort(b))
    return float(np.corrcoef(ra, rb)[0, 1])
result = {"note": "the cut's estimated error against its PSNR (tag common-error); identical cuts counted once; deterministic, one run",
          "spearman_all": spearman([r['est'] for r in cuts], [r['cut_db'] for r in cuts]), "per_budget": {}, "per_case": {}, "rows": cuts}
for b in ['coarsest', '5', '10', '25', '50']:
    s = [r for r in cuts if r['budget'] == b]
    if len(s) > 2: result["per_budget"][b] = spearman([r['est'] for r in s], [r['cut_db'] for r in s])
for c in sorted({r['case'] for r in cuts}):
    s = [r for r in cuts if r['case'] == c]
    result["per_case"][c] = spearman([r['est'] for r in s], [r['cut_db'] for r in s])
json.dump(result, open('bench/results/fidelity_rank.json', 'w'), indent=1)
print(json.dumps({k: v for k, v in result.items() if k != 'rows'}, indent=1))
