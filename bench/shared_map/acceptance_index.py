#!/usr/bin/env python3
# Birk & Carpin 2006 acceptance index of grid A against grid B (ROS trinary PGM + YAML as `waymark
# map grid` and `slam replay` write them, one frame and resolution): agreeing cells over agreeing
# plus disagreeing, over the cells known (free or occupied) in both. Free cells dominate, so the
# index moves little: on ACES, robot 1's grid against the single session's scored 0.933 aligned,
# 0.887 shifted by 1 m. Usage: acceptance_index.py A.pgm B.pgm
import sys, re
def load(pgm):
    yaml = open(pgm[:-4] + '.yaml').read()
    res = float(re.search(r'resolution: ([\d.]+)', yaml).group(1))
    ox, oy = map(float, re.search(r'origin: \[([-\d.e]+), ([-\d.e]+)', yaml).groups())
    data = open(pgm, 'rb').read()
    i = 0
    tokens = []  # the header: P5, width, height, maxval (comments skipped)
    while len(tokens) < 4:
        while data[i:i+1].isspace(): i += 1
        if data[i:i+1] == b'#':
            while data[i:i+1] != b'\n': i += 1
            continue
        j = i
        while not data[j:j+1].isspace(): j += 1
        tokens.append(data[i:j]); i = j
    i += 1
    w, h = int(tokens[1]), int(tokens[2])
    return res, ox, oy, w, h, data[i:i + w * h]
def cell(v): return 1 if v == 0 else (0 if v == 254 else None)  # occupied, free, unknown
ra, oxa, oya, wa, ha, a = load(sys.argv[1]); rb, oxb, oyb, wb, hb, b = load(sys.argv[2])
assert abs(ra - rb) < 1e-9
dx, dy = round((oxa - oxb) / ra), round((oya - oyb) / ra)
agree = disagree = 0
for ya in range(ha):
    # PGM rows run from the top: row r is cell row (h - 1 - r) above the origin
    gy = (ha - 1 - ya) + dy
    if gy < 0 or gy >= hb: continue
    rowb = (hb - 1 - gy) * wb
    rowa = ya * wa
    for xa in range(wa):
        gx = xa + dx
        if gx < 0 or gx >= wb: continue
        va, vb = cell(a[rowa + xa]), cell(b[rowb + gx])
        if va is None or vb is None: continue
        if va == vb: agree += 1
        else: disagree += 1
print(f"{agree / (agree + disagree):.3f} ({agree + disagree} cells known in both)")
