//! The CLI's human-readable report (`--json` prints the report itself).

use std::fmt;

use fast_reject::search::MatchReport;

/// A search report laid out as a table.
pub struct Table<'a>(pub &'a MatchReport);

/// A readable table: template, grid, every layer, the instances, timings.
impl fmt::Display for Table<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let report = self.0;
        let t = &report.template;
        writeln!(
            f,
            "template: centre ({}, {}, {}), radius {}",
            num(t.center[0]),
            num(t.center[1]),
            num(t.center[2]),
            num(t.radius)
        )?;
        if let Some(g) = &report.grid {
            writeln!(
                f,
                "grid: {} voxels on the longest side, voxel {}, {} candidate points",
                g.resolution,
                num(g.voxel_size),
                g.skin_voxels
            )?;
            if g.windows > 0 {
                writeln!(f, "large parts searched in {} windows", g.windows)?;
            }
        }
        if let Some(g) = &report.gpu {
            writeln!(f, "harmonics layers on the GPU: {}", g.adapter)?;
            if let Some(reason) = &g.fallback {
                writeln!(f, "  some layers went back to the CPU: {reason}")?;
            }
        }
        if let Some(s) = &report.surface {
            writeln!(
                f,
                "surface: {} welded vertices (the candidate points), {} triangles",
                s.vertices, s.triangles
            )?;
        }
        writeln!(f)?;
        writeln!(
            f,
            "{:<10} {:>5} {:>8} {:>10} {:>10} {:>9}",
            "stage", "layer", "radius", "candidates", "survivors", "ms"
        )?;
        for s in &report.stages {
            writeln!(
                f,
                "{:<10} {:>5} {:>8} {:>10} {:>10} {:>9.1}",
                s.descriptor,
                s.layer,
                num(s.radius),
                s.candidates,
                s.survivors,
                s.ms
            )?;
        }
        writeln!(f, "\n{} instance(s):", report.instances.len())?;
        for (i, inst) in report.instances.iter().enumerate() {
            let p = inst.position;
            write!(
                f,
                "  #{:<3} at ({}, {}, {})  distance {}",
                i + 1,
                num(p[0]),
                num(p[1]),
                num(p[2]),
                num(inst.distance),
            )?;
            if let Some(score) = inst.score {
                write!(f, "  score {score:.3}")?;
            }
            if let Some(residual) = inst.residual {
                write!(f, "  residual {residual:.2e}")?;
            }
            write!(f, "  support {}", inst.support)?;
            match inst.whole {
                Some(true) => writeln!(f, "  whole copy")?,
                Some(false) => writeln!(f, "  part of a larger whole")?,
                None => writeln!(f)?,
            }
        }
        let tm = &report.timings;
        write!(
            f,
            "\ntime (ms): load {:.1}, voxelize/weld {:.1}, template {:.1}, match {:.1}, group {:.1}, total {:.1}",
            tm.load,
            tm.voxelize + tm.surface,
            tm.template,
            tm.match_,
            tm.group,
            tm.total()
        )
    }
}

/// A coordinate or a length as a person reads it: four decimals where
/// that is readable, scientific notation for the very large and the very
/// small (1e308 is not three hundred digits).
pub fn num(x: f64) -> String {
    if x == 0.0 || (1e-3..1e6).contains(&x.abs()) || !x.is_finite() {
        format!("{x:.4}")
    } else {
        format!("{x:.3e}")
    }
}
