"""Write tests/data/single_coefficient_golden.json: landings and cache keys computed by the code
before static/kinetic friction existed (commit 5c4b492 of main), the oracle of
tests/transition_builder/test_friction_pair.py ("one coefficient gives today's landings exactly, same keys").

Run from the repository root with the code to record: ``python tests/data/make_single_coefficient_golden.py``.
"""
import json
import sys

import numpy as np

from transition_builder.scene import Scene, scene_from_options
from transition_builder.sim import TraySimulator

#: (shape, friction, contact, action, start poses) of the recorded tilts.
CASES = [("allen-key", "0.3", "coulomb", "E", [(60.0, 80.0, 0.3), (120.0, 50.0, 2.0), (100.0, 150.0, 4.4)]),
         ("allen-key", "0.3", "coulomb", "NE", [(60.0, 80.0, 0.3), (140.0, 120.0, 5.5)]),
         ("allen-key", "0.45", "coulomb", "SW", [(90.0, 110.0, 1.0), (150.0, 60.0, 3.0)]),
         ("allen-key", "map:medium:2", "coulomb", "N", [(70.0, 60.0, 0.7), (130.0, 90.0, 2.5)]),
         ("triangle:3", "0.3", "coulomb", "W", [(100.0, 100.0, 1.2)]),
         ("allen-key", "0.3", "sphere", "E", [(60.0, 80.0, 0.3)])]

#: scenes whose content hash (the cache key's scene part) must not change.
KEY_SCENES = [dict(shape_spec="allen-key"), dict(shape_spec="allen-key", friction_spec=0.2),
              dict(shape_spec="allen-key", friction_spec="map:high:4"),
              dict(shape_spec="triangle:5", friction_spec="0.35", tilt_deg=25.0),
              dict(shape_spec="allen-key", contact="sphere")]


def record():
    landings = []
    for shape, fr, contact, action, poses in CASES:
        sc = scene_from_options(shape, fr, contact=contact)
        with TraySimulator(sc) as sim:
            for p in poses:
                sim.fresh_start()
                rest, status = sim.tilt([p], action)
                landings.append({"shape": shape, "friction": fr, "contact": contact, "action": action,
                                 "start": list(p), "rest": [float(v) for v in rest[0]], "status": int(status[0])})
    keys = [{"options": kw, "hash": scene_from_options(**kw).content_hash()} for kw in KEY_SCENES]
    base = Scene.from_dict({"shape": "allen-key", "friction": "map:low:1", "base_mu": 0.4})
    keys.append({"scene_dict": {"shape": "allen-key", "friction": "map:low:1", "base_mu": 0.4},
                 "hash": base.content_hash()})
    return {"landings": landings, "keys": keys}


if __name__ == "__main__":
    out = record()
    path = sys.argv[1] if len(sys.argv) > 1 else "tests/data/single_coefficient_golden.json"
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
    print(len(out["landings"]), "landings;", np.sum([r["status"] == 0 for r in out["landings"]]), "ok")
