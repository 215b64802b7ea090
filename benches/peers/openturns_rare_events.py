"""OpenTURNS' rare-event estimators on the closed forms of tests/rare_events.rs, for a
side-by-side comparison with `cargo run --release --example rare_events`
(docs/reliability.md, "Against OpenTURNS").

For each case and method, 20 seeds: the mean number of limit-state calls, the mean
estimate and the empirical coefficient of variation, sqrt(mean((p - truth)^2)) / truth.
The limit state is counted through a vectorised Python function, so every call OpenTURNS
makes is counted, whatever the space it works in.

Run: python3 -m pip install openturns numpy && python3 benches/peers/openturns_rare_events.py
"""

import math

import numpy as np
import openturns as ot

SEEDS = 20


def linear(d, beta):
    return lambda u: beta - u.sum(axis=1) / math.sqrt(d)


def series(beta):
    return lambda u: np.minimum(np.minimum(beta - u[:, 0], beta - u[:, 1]), beta - u[:, 2])


def chi_square(c):
    return lambda u: c - (u * u).sum(axis=1)


CASES = [
    ("linear 7-d", 7, linear(7, 4.753), 1.00210e-6),
    ("linear 50-d", 50, linear(50, 4.753), 1.00210e-6),
    ("series 7-d", 7, series(4.5), 1.0 - ot.Normal().computeCDF(4.5) ** 3),
    # |u|^2 >= c with P = 1e-5 for d = 7
    ("chi-square 7-d", 7, chi_square(ot.ChiSquare(7).computeQuantile(1e-5, True)[0]), 1e-5),
]


def algorithm(name, event):
    if name == "NAIS":
        a = ot.NAIS(event, 0.1)
        a.setMaximumOuterSampling(1000)
    elif name == "CE-IS":
        a = ot.StandardSpaceCrossEntropyImportanceSampling(event, 0.3)
        a.setMaximumOuterSampling(1000)
    else:
        a = ot.SubsetSampling(event)
        a.setMaximumOuterSampling(int(name.split()[1]))
        a.setConditionalProbability(0.1)
    return a


def main():
    for case, d, g, truth in CASES:
        for method in ["NAIS", "CE-IS", "SubsetSampling 1000", "SubsetSampling 2000"]:
            calls = [0]

            def sample(x):
                u = np.asarray(x)
                calls[0] += len(u)
                return g(u).reshape(-1, 1)

            f = ot.PythonFunction(d, 1, func_sample=sample)
            event = ot.ThresholdEvent(
                ot.CompositeRandomVector(f, ot.RandomVector(ot.Normal(d))), ot.LessOrEqual(), 0.0
            )
            p, n = [], []
            for seed in range(SEEDS):
                ot.RandomGenerator.SetSeed(seed + 1)
                calls[0] = 0
                a = algorithm(method, event)
                a.run()
                p.append(a.getResult().getProbabilityEstimate())
                n.append(calls[0])
            p = np.array(p)
            cov = math.sqrt(np.mean((p - truth) ** 2)) / truth
            print(
                f"{case:15s} {method:20s} calls {np.mean(n):8.0f}  mean/truth {p.mean() / truth:6.3f}  empirical CoV {cov:6.3f}",
                flush=True,
            )


if __name__ == "__main__":
    main()
