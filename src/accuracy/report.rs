//! What a sweep's rows say: the Pareto front of error against GPU time, the equal-time and
//! equal-quality summaries, and the rows as CSV and as a Markdown table.

use serde::Serialize;

use super::{Parameter, Row};

/// The summaries of a sweep: the least error within the base setting's time (equal time),
/// and the least time that reaches the FLIP threshold (equal quality).
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    pub base_gpu_s: f64,
    pub base_flip_mean: f64,
    /// The row with the least FLIP mean among those no slower than the base.
    pub equal_time: Option<Pick>,
    /// The fastest row whose FLIP mean is at most the threshold.
    pub equal_quality: Option<Pick>,
    pub threshold: f64,
    /// The rows on the Pareto front of FLIP mean against GPU time (indices into the rows).
    pub pareto: Vec<usize>,
}

#[derive(Clone, Debug, Serialize)]
pub struct Pick {
    pub parameter: Parameter,
    pub value: String,
    pub gpu_s: f64,
    pub flip_mean: f64,
}

fn pick(r: &Row) -> Pick {
    Pick { parameter: r.parameter, value: r.value.clone(), gpu_s: r.gpu_s, flip_mean: r.error.flip_mean }
}

/// The rows no other row beats in both time and error.
pub fn pareto(rows: &[Row]) -> Vec<usize> {
    (0..rows.len())
        .filter(|&i| {
            let a = &rows[i];
            !rows.iter().any(|b| {
                (b.gpu_s <= a.gpu_s && b.error.flip_mean <= a.error.flip_mean)
                    && (b.gpu_s < a.gpu_s || b.error.flip_mean < a.error.flip_mean)
            })
        })
        .collect()
}

pub fn summary(rows: &[Row], threshold: f64) -> Summary {
    let base = rows.iter().find(|r| r.base);
    let (base_gpu_s, base_flip_mean) = base.map_or((f64::NAN, f64::NAN), |b| (b.gpu_s, b.error.flip_mean));
    let equal_time = rows
        .iter()
        .filter(|r| r.gpu_s <= base_gpu_s)
        .min_by(|a, b| a.error.flip_mean.total_cmp(&b.error.flip_mean))
        .map(pick);
    let equal_quality = rows
        .iter()
        .filter(|r| r.error.flip_mean <= threshold)
        .min_by(|a, b| a.gpu_s.total_cmp(&b.gpu_s))
        .map(pick);
    Summary { base_gpu_s, base_flip_mean, equal_time, equal_quality, threshold, pareto: pareto(rows) }
}

/// The rows as CSV (a header line, then one line per row).
pub fn csv(rows: &[Row]) -> String {
    let mut out = String::from(
        "parameter,value,base,gpu_s,preprocess_s,table_bytes,rmse,psnr,relmse,flip_mean,flip_p99,id_disagreement,max_t_error,self_hits,blocked_share\n",
    );
    for r in rows {
        out += &format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            r.parameter.name(),
            r.value.replace(',', ";"),
            r.base,
            r.gpu_s,
            r.preprocess_s,
            r.table_bytes,
            r.error.rmse,
            r.error.psnr.map_or(String::new(), |p| p.to_string()),
            r.error.relmse,
            r.error.flip_mean,
            r.error.flip_p99,
            r.hits.id_disagreement,
            r.hits.max_t_error,
            r.self_hits,
            r.blocked_share
        );
    }
    out
}

/// The rows and summaries as the text table `cuberay accuracy` prints.
pub fn table(rows: &[Row], summary: &Summary) -> String {
    let mut out = String::from(
        "| parameter | value | GPU ms | preprocess s | MiB | RMSE | PSNR dB | relMSE | FLIP mean | FLIP p99 | ids differ | max Δt/size | self-hits | blocked |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for (i, r) in rows.iter().enumerate() {
        let mark = if summary.pareto.contains(&i) { " *" } else { "" };
        out += &format!(
            "| {} | {}{}{} | {:.2} | {:.3} | {:.1} | {:.5} | {} | {:.5} | {:.4} | {:.4} | {:.4} | {:.2e} | {} | {:.4} |\n",
            r.parameter.name(),
            r.value,
            if r.base { " (base)" } else { "" },
            mark,
            r.gpu_s * 1e3,
            r.preprocess_s,
            r.table_bytes as f64 / (1u64 << 20) as f64,
            r.error.rmse,
            r.error.psnr.map_or("∞".into(), |p| format!("{p:.1}")),
            r.error.relmse,
            r.error.flip_mean,
            r.error.flip_p99,
            r.hits.id_disagreement,
            r.hits.max_t_error,
            r.self_hits,
            r.blocked_share
        );
    }
    out += "\n* on the Pareto front of FLIP mean against GPU time\n";
    out += &format!("base: FLIP mean {:.4} in {:.2} ms\n", summary.base_flip_mean, summary.base_gpu_s * 1e3);
    match &summary.equal_time {
        Some(p) => {
            out += &format!(
                "equal time (at most the base's {:.2} ms): the least error is {} = {}, FLIP mean {:.4} in {:.2} ms\n",
                summary.base_gpu_s * 1e3,
                p.parameter.name(),
                p.value,
                p.flip_mean,
                p.gpu_s * 1e3
            )
        }
        None => out += "equal time: no row is as fast as the base\n",
    }
    match &summary.equal_quality {
        Some(p) => {
            out += &format!(
                "equal quality (FLIP mean at most {}): the fastest is {} = {}, {:.2} ms (FLIP mean {:.4})\n",
                summary.threshold,
                p.parameter.name(),
                p.value,
                p.gpu_s * 1e3,
                p.flip_mean
            )
        }
        None => out += &format!("equal quality: no row reaches a FLIP mean of {}\n", summary.threshold),
    }
    out
}
