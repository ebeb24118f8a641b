#!/usr/bin/env python3
"""Writes scenes/craniotomy.json: a procedural head (scalp, skull, CSF, brain) and its craniotomy.

Kept next to the tests so the numbers below (layer sizes, blade path) are reviewable as code;
the scene file is the artefact the CLI and the tests read.

Materials come from `materialFromPrimitive` (region = the primitive whose own field is largest).
Nested tissues built from concentric ellipsoids would all be claimed by the outermost one, so
the tissues use quadric points with different peaks: the head shell is made of *flat* quadrics
(peak 0.51 scalp, 0.56 skull: their fields never exceed that), the CSF a quadric of peak 2 and
the brain quadrics of peak 30. Each inner tissue's field overtakes the outer ones within about
one or two hundredths of a unit of its own surface (checked by tests/evaluation).
"""
import json, math, sys

def k(peak):  # iso radius of a quadric point of support 1 and scale 1
    return math.sqrt(1 - math.sqrt(0.5 / peak))

def quadric(id_, semi, peak, colour, centre=(0, 0, 0), rotate=None):
    t = {"translate": list(centre), "scale": [round(s / k(peak), 5) for s in semi]}
    if rotate: t["rotate"] = rotate
    return {"type": "quadricPoint", "id": id_, "scale": peak, "transform": t, "colour": colour}

SCALP = (0.80, 0.88, 1.00)        # semi-axes x (width), y (height), z (front-back)
SKULL_OUT = (0.70, 0.78, 0.90)    # scalp 0.10 thick
SKULL_IN = (0.56, 0.64, 0.76)     # bone 0.14 thick
CSF = (0.35, 0.43, 0.55)          # epidural gap 0.21: the dura is stripped from the bone
BRAIN_HEMI = (0.15, 0.35, 0.47)   # each hemisphere; CSF 0.08 around the brain

scalp_c, bone_c, csf_c, brain_c = [0.85, 0.66, 0.55], [0.93, 0.91, 0.84], [0.55, 0.75, 0.95], [0.87, 0.6, 0.62]
brain = [quadric("left hemisphere", BRAIN_HEMI, 30, brain_c, (-0.13, 0, 0)),
         quadric("right hemisphere", BRAIN_HEMI, 30, brain_c, (0.13, 0, 0))]
for side in (-1, 1):  # three medial-lateral gyri blended on top of each hemisphere
    for z in (-0.22, 0.0, 0.22):
        brain.append(quadric(f"gyrus {'L' if side < 0 else 'R'}{z:+.2f}", (0.12, 0.05, 0.05), 30, brain_c,
                             (side * 0.14, 0.33 - 0.25 * z * z, z)))

root = {"type": "union", "id": "head", "children": [
    {"type": "difference", "id": "scalp and skull", "children": [
        {"type": "union", "children": [quadric("scalp", SCALP, 0.51, scalp_c), quadric("skull outer", SKULL_OUT, 0.56, bone_c)]},
        quadric("skull inner", SKULL_IN, 0.56, bone_c)]},
    {"type": "union", "id": "intracranial", "children": [
        quadric("CSF", CSF, 2.0, csf_c),
        {"type": "blend", "id": "brain", "children": brain}]}]}
materials = ([{"E": 1e6, "nu": 0.45, "density": 1100},    # scalp
              {"E": 1e7, "nu": 0.3, "density": 1900},     # skull outer
              {"E": 1e7, "nu": 0.3, "density": 1900},     # skull inner (claims only the empty gap)
              {"E": 2e4, "nu": 0.45, "density": 1000}] +  # CSF (a very soft solid)
             [{"E": 1e5, "nu": 0.45, "density": 1040}] * len(brain))

def radial(d, semi):  # distance along unit direction d to the ellipsoid with these semi-axes
    return 1 / math.sqrt(sum((d[i] / semi[i]) ** 2 for i in range(3)))

# The bone flap: an oval on the crown, cut by a radial saw blade that reaches from the middle of
# the epidural gap to outside the scalp. A radial cut makes the flap a wedge that narrows
# inwards, so it can only leave outwards. Keyframe times are simulation times: the saw closes
# the oval in 0.2 s while the head is simulated.
blade, n = [], 40
for i in range(n + 2):  # two keyframes past the start so the ring closes
    th = 2 * math.pi * i / n
    p = (0.15 + 0.34 * math.cos(th), 1.0, 0.05 + 0.44 * math.sin(th))
    l = math.sqrt(sum(c * c for c in p))
    d = [c / l for c in p]
    ra = 0.5 * (radial(d, SKULL_IN) + radial(d, CSF))
    rb = radial(d, SCALP) + 0.15
    blade.append({"t": round(i / n * 0.2, 5), "a": [round(c * ra, 5) for c in d], "b": [round(c * rb, 5) for c in d]})

LIFT_START = 0.22          # the flap is lifted once it is free, from this time on

gap_mid = [0.5 * (a + b) / 0.4542 for a, b in zip(SKULL_IN, CSF)]
fixed = {"type": "union", "id": "clamp and brain stem", "children": [
    {"type": "difference", "children": [  # the head shell below y = 0.3 is held by the head clamp
        {"type": "cube", "centre": [0, -0.7, 0], "halfExtents": [2, 1.0, 2], "support": 0.05},
        {"type": "point", "transform": {"scale": gap_mid}}]},
    {"type": "cube", "centre": [0, -0.62, 0], "halfExtents": [0.2, 0.25, 0.2], "support": 0.05}]}  # brain stem

scene = {
    "blobvk": 1,
    "name": "craniotomy: procedural head, bone flap cut by a saw, brain under a retractor",
    "camera": {"target": [0, 0.2, 0], "azimuthDeg": 30, "elevationDeg": 35, "distance": 4.5, "fovYDeg": 45},
    # The flat quadrics reach far beyond their surfaces (support ~10x the iso radius), so the
    # compiled bounds are huge: give the head's box.
    "grid": {"resolution": 64, "bounds": {"lo": [-0.95, -1.0, -1.15], "hi": [0.95, 1.0, 1.15]}},
    "root": root,
    "simulation": {
        # TetGen on the polygonized head, cleaned up to 2.7 cells per edge (~37k tets); the gap
        # between skull and brain gets a hole point from the field, so the flap can leave.
        "mesher": "tetgen",
        "tetgen": {"remeshEdge": 2.7},
        "materials": materials,
        "materialFromPrimitive": True,
        "timeStep": 0.01,
        "gravity": [0, -9.81, 0],
        "damping": {"mass": 0.5, "stiffness": 0.01},
        "solver": {"maxIterations": 500, "tolerance": 1e-3},
        "fixed": fixed,
        # The retractor waits above the crown until the flap has been lifted out of its way,
        # then enters the opening and presses the CSF and brain (held at the brain stem).
        "tools": [{"shape": "capsule", "radius": 0.06, "halfLength": 0.12, "stiffness": 20000,
                   "path": [{"t": 0, "position": [0.15, 1.6, 0.05], "orientation": [0.7071068, 0.7071068, 0, 0]},
                            {"t": LIFT_START + 0.2, "position": [0.15, 1.6, 0.05]},
                            {"t": LIFT_START + 0.4, "position": [0.15, 0.36, 0.05]},
                            {"t": LIFT_START + 0.6, "position": [0.15, 0.36, 0.05]}]}],
        "blade": blade,
        # Once the saw has closed the oval the flap is free: grasp it and lift it up and aside
        # (towards -x, away from the retractor's way in), tilting it.
        "lift": {"near": [0.15, 0.85, 0.05], "start": LIFT_START,
                 "path": [{"t": 0, "translate": [0, 0, 0]},
                          {"t": 0.1, "translate": [0, 0.25, 0]},
                          {"t": 0.25, "translate": [-1.0, 0.5, 0], "rotate": {"axis": [0, 0, 1], "degrees": 40}}]},
        "steps": 80,
        "frameEvery": 5}}
out = sys.argv[1] if len(sys.argv) > 1 else "scenes/craniotomy.json"
with open(out, "w") as f:
    f.write(json.dumps(scene, indent=1) + "\n")
