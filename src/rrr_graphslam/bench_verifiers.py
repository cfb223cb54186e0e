"""The verifiers table of scripts/bench_rrr (--verifiers): RRR beside the other families of
loop-closure verification that rrr_offline runs on the same candidates (--verifier pcm, scgp,
gnc with either loss), on synthetic inputs over seeds, on the KITTI candidate sets and on
Bicocca B25b: precision, recall, map harm (synthetic inputs) and time, then the worst per
verifier."""

from typing import NamedTuple, Optional

from .evaluation import MapHarm, Score

VERIFIERS = (
    ("rrr", []),
    ("pcm", ["--verifier", "pcm"]),
    ("scgp", ["--verifier", "scgp"]),
    ("gnc tls", ["--verifier", "gnc"]),
    ("gnc gm", ["--verifier", "gnc", "--gnc-loss", "gm"]),
)
# Small and mid-size graphs, each outlier family: random, grouped near true revisits, aliased
# corridors (groups of 20 sharing one wrong offset).
VERIFIER_INPUTS = (
    "manhattanOlson3500_olson:random:1000",
    "manhattanOlson3500_olson:local-grouped:500",
    "manhattanOlson3500_olson:aliased:1000",
    "intel:random:500",
    "intel:local-grouped:500",
    "intel:aliased:500",
    "csail:aliased:300",
    "ringCity:aliased:300",
)
VERIFIER_GROUP_SIZE = {"aliased": 20}


class VerifierRow(NamedTuple):
    input: str
    seed: Optional[int]
    verifier: str
    score: Score
    run: dict
    harm: Optional[MapHarm]


def run_verifiers(args, optimizer, specs, kitti, b25b):
    """The table: every verifier on each NAME:KIND:COUNT of `specs` for every seed of
    args.verifier_seeds, then on `kitti` and `b25b` ((label, graph, truth) inputs the main table
    also runs). Decisions go beside the input as GRAPH.verifier-NAME.tsv."""
    from .bench import harm_text, scored_run, synthetic_input, synthetic_map_harm

    print("| input | seed | verifier | precision | recall | map harm | time s |")
    print("|---|---|---|---|---|---|---|")
    rows = []

    def decide(label, seed, graph, truth, harm_of=None):
        for verifier, extra in VERIFIERS:
            slug = verifier.replace(" ", "-")
            optimized = f"{graph}.verifier-{slug}.opt.g2o"
            output = ["--output", optimized] if harm_of else []
            s, r = scored_run(args.rrr_offline, graph, truth, f"{graph}.verifier-{slug}.tsv",
                              [*extra, *output])
            harm = synthetic_map_harm(args.data, args.cache, optimizer, harm_of,
                                      optimized) if harm_of else None
            rows.append(VerifierRow(label, seed, verifier, s, r, harm))
            print(f"| {label} | {seed if seed is not None else '-'} | {verifier} | "
                  f"{s.precision:.4f} | {s.recall:.4f} | {harm_text(harm)} | {r['time']:.2f} |",
                  flush=True)

    for spec in specs:
        name, kind, count = spec.split(":")
        for seed in args.verifier_seeds:
            graph, truth = synthetic_input(args.data, args.cache, optimizer, name, kind,
                                           int(count), seed, VERIFIER_GROUP_SIZE.get(kind, 10))
            decide(f"{name} {kind} {count}", seed, graph, truth, harm_of=name)
    for label, graph, truth in list(kitti) + list(b25b):
        decide(label, None, graph, truth)
    print()
    for line in verifier_summary(rows):
        print(line)


def verifier_summary(rows):
    """Per verifier over every input: the worst precision and recall, the inputs whose map it
    harmed, the total time."""
    lines = ["| verifier | inputs | worst precision | worst recall | maps harmed | time s (total) |",
             "|---|---|---|---|---|---|"]
    for verifier, _ in VERIFIERS:
        rs = [r for r in rows if r.verifier == verifier]
        if not rs:
            continue
        harmed = [f"{r.input} s{r.seed}" for r in rs if r.harm is not None and r.harm.harmed]
        scored = sum(r.harm is not None for r in rs)
        lines.append(f"| {verifier} | {len(rs)} | {min(r.score.precision for r in rs):.4f} | "
                     f"{min(r.score.recall for r in rs):.4f} | {len(harmed)} of {scored}"
                     + (f" ({', '.join(harmed)})" if harmed else "")
                     + f" | {sum(r.run['time'] for r in rs):.1f} |")
    return lines
