"""Tables of docs/atlas.md from benchmarks/atlas/atlas.json (the prose around them is written by hand).

    python3 benchmarks/atlas/make_docs.py > /tmp/atlas_tables.md
"""
import sys
from pathlib import Path

from pinclear.studies.bench import atlas

HERE = Path(__file__).resolve().parent


def main(path=HERE / "atlas.json"):
    res = atlas.load(path)
    print(f"<!-- generated from benchmarks/atlas/atlas.json ({res['created']}, {len(res['rows'])} cells) -->\n")
    print("### All scenes\n")
    print(atlas.summary_table(res))
    print("\n### All formulation + integrator pairs\n")
    print(atlas.method_table(res))
    print("\n### Scene by scene\n")
    print("Cells: log10 of the error at t_end (max over coordinates of pin.difference(q_ref, q)), or the "
          "failure reason and the time it happened.\n")
    for label, sc in res["scenes"].items():
        print(f"#### {label}\n")
        print(f"t_end {sc['t_end']:g} s; reference: {sc['reference']}; energy: {sc['energy_kind']}; "
              f"budget {sc['budget_cpu_s']:g} CPU s per cell.")
        if sc["skipped"]:
            print("Not run: " + "; ".join(f"{k} ({v.split(':')[0] if 'cannot express' not in v else 'refuses the closure type'})"
                                          for k, v in sc["skipped"].items()) + ".")
        print()
        fn = atlas._fname(label)
        print(f"![heatmap {label}](../benchmarks/atlas/heatmap_{fn}.png) "
              f"![work-precision {label}](../benchmarks/atlas/work_precision_{fn}.png)\n")
        print(atlas.table(res, label))
        print()


if __name__ == "__main__":
    main(*sys.argv[1:])
