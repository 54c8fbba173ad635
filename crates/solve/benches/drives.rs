//! Benchmark: how the cost of a simulation grows with the circuit.
//!
//! `n` meter-out drives (5/2 valve, speed-control valve, cylinder, cycler)
//! on one supply line and manifold, n = 1 … 64, simulated for 3 s from rest
//! at rtol = atol = 1e-4, with the Jacobian from the circuit's structure
//! (and, above 40 states, the sparse LU), and for n ≤ 16 also with plain
//! finite differences and a dense LU, the way the integrator worked before.
//! The drives have staggered strokes (their events fall at different
//! instants, as on a real machine); from n = 8 the same circuit with all
//! drives alike (switching together) is run as well, to separate the cost of
//! the linear algebra from the cost of the events.
//! The group `drives_large` runs n = 128 and 256 for 6 s (staggered and in
//! step, structured only; about four minutes): `cargo bench -p pneumo-solve
//! --bench drives -- drives_large`, the other sizes with `-- drives/`.
//! The 6 s runs of the issue, with the integrator's counts, come from the
//! example `drives_scaling` (see docs/performance.md).
//! docs/performance.md lists the medians and the fitted exponent k of
//! time ∝ n^k. Run: `cargo bench -p pneumo-solve --bench drives`.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};

#[path = "../tests/common/drives.rs"]
mod drives;

fn build(n: usize, structured: bool, staggered: bool) -> (solve::Model, solve::SimOptions) {
    let circuit = graph::build(&drives::drives(n, staggered)).expect("the drives circuit builds");
    let mut opts = solve::options_from(&circuit.simulation).expect("settings");
    opts.sample_interval = 0.0;
    opts.jacobian = if structured { solve::JacobianMethod::GroupedDifferences } else { solve::JacobianMethod::PlainDifferences };
    (solve::Model::new(circuit), opts)
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("drives");
    group.sample_size(10);
    for n in [1usize, 2, 4, 8, 16, 32, 64] {
        group.throughput(Throughput::Elements(n as u64));
        let mut variants = vec![(true, true, "structured")];
        if n <= 16 {
            variants.push((false, true, "dense"));
        }
        if n >= 8 {
            variants.push((true, false, "structured_in_step"));
        }
        for (structured, staggered, label) in variants {
            group.bench_function(format!("{label}_{n}"), |b| {
                b.iter_batched(
                    || build(n, structured, staggered),
                    |(mut model, opts)| {
                        // (with many drives in step the shared supply line sags and
                        // the first cycle may not end within 3 s: no cycle count is
                        // asserted)
                        let r = solve::simulate(&mut model, &opts).expect("simulates");
                        r.t_final
                    },
                    BatchSize::SmallInput,
                )
            });
        }
    }
    group.finish();

    // hundreds of drives, 6 s simulated as in the issue (in 3 s, 256 drives
    // on this supply have not ended their first stroke, staggered or not):
    // 10 runs of a few seconds each, so no warm-up beyond one run
    let mut group = c.benchmark_group("drives_large");
    group.sample_size(10).warm_up_time(std::time::Duration::from_millis(1)).measurement_time(std::time::Duration::from_secs(1));
    for n in [128usize, 256] {
        group.throughput(Throughput::Elements(n as u64));
        for (staggered, label) in [(true, "structured"), (false, "structured_in_step")] {
            group.bench_function(format!("{label}_{n}"), |b| {
                b.iter_batched(
                    || {
                        let (model, mut opts) = build(n, true, staggered);
                        opts.t_end = 6.0;
                        (model, opts)
                    },
                    |(mut model, opts)| solve::simulate(&mut model, &opts).expect("simulates").t_final,
                    BatchSize::SmallInput,
                )
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
