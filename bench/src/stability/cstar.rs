//! C*, the critical CFL number of the forced-dt plane: per method × material (and per Young's
//! modulus), the smallest swept C at which a run is not stable and the largest C below it.

use super::*;

/// The C* column of Young's modulus `e_pa`: `c_first_unstable_e6` for 1e6 Pa.
pub(super) fn cstar_key(e_pa: f64) -> String {
    format!("c_first_unstable_e{}", e_pa.log10().round())
}

/// C* per method × material (and per E): the smallest swept C at which a run is not stable, and
/// the largest C below it (every E stable there).
pub(super) fn critical_cfl(
    p: &Plane,
    methods: &[&'static str],
    materials: &[&'static str],
    runs: &[RunSpec],
    outcomes: &[Outcome],
) -> Vec<Value> {
    let cs = &p.x.1;
    let mut out = Vec::new();
    for &method in methods {
        for &material in materials {
            let mine: Vec<(&RunSpec, &Outcome)> = runs
                .iter()
                .zip(outcomes)
                .filter(|(s, _)| s.method == method && s.material == material)
                .collect();
            let first_unstable_at = |filter: &dyn Fn(&RunSpec) -> bool| {
                cs.iter().position(|&c| {
                    mine.iter()
                        .any(|(s, o)| filter(s) && s.cfl == c && !o.stable())
                })
            };
            let all = first_unstable_at(&|_| true);
            let per_e: Vec<Value> =
                p.y.1
                    .iter()
                    .map(|&e| {
                        let k = first_unstable_at(&|s: &RunSpec| s.youngs_modulus_pa == e);
                        json!(k.map(|k| cs[k]))
                    })
                    .collect();
            let mut r = json!({
                "bench": "stability_cstar",
                "method": method,
                "material": material,
                "c_last_stable": match all { Some(0) => None, Some(k) => Some(cs[k - 1]), None => cs.last().copied() },
                "c_first_unstable": all.map(|k| cs[k]),
            });
            for (e, c) in p.y.1.iter().zip(per_e) {
                r[cstar_key(*e)] = c;
            }
            out.push(r);
        }
    }
    out
}
