"""Medians of the H200 runs in this folder: python3 summarize.py run3-stats.jsonl"""
import collections, json, statistics as st, sys

agg = collections.defaultdict(list)
for line in open(sys.argv[1]):
    d = json.loads(line)
    tag, s = d["tag"], d["s"]
    if tag == "warm":
        continue
    base = tag.rsplit("-", 1)[0] if tag[-1].isdigit() and tag[-2] == "-" else tag
    agg[base].append(s)
for k, v in agg.items():
    g = [x.get("gpu") or {} for x in v]
    gms = st.median(x.get("gpu_ms_total", 0) for x in g)
    r = st.median(x["render_ms"] for x in v)
    rays = v[0]["rays"]["total"]
    ph = {p: round(st.median(x.get("phases_ms", {}).get(p, 0) for x in g), 1) for p in g[0].get("phases_ms", {})} if g[0] else {}
    line = f"{k:28s} n={len(v)} render {r:8.1f} ms  {rays / r / 1e3:7.1f} Mr/s wall"
    if gms:
        line += f"  gpu {gms:8.1f} ms {rays / gms / 1e3:7.1f} Mr/s"
    print(line, ph if ph else "", "rays", v[0]["rays"])
