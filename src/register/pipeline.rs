//! The paper's solve schedule (FBT Sec. 5, "Implementation
//! considerations") over up to three dictionaries:
//!
//! 1. initial transformations in a small dictionary (typically LBO with
//!    m ≤ 4): sparse (Eq. 23) or linear (Eq. 22);
//! 2. change to the main dictionary (Eq. 24);
//! 3. a few iterations of the average energy E_total (Eq. 11);
//! 4. a few iterations of the minimal energy E_mn (Eq. 12), which selects
//!    the example ℓ* closest to the target;
//! 5. change to a richer dictionary (Eq. 24) and more E_mn iterations.
//!
//! [`FbtPipeline`] is the precomputation per (mesh set, dictionaries):
//! one [`FbtModel`] per stage and the change-of-dictionary matrices.
//! [`FbtPipeline::systems`] factorises the stage systems for one constraint
//! matrix `H`; [`PipelineSystems::solve`] is then cheap and can be called
//! for many targets `Y` (DESIGN rule 2).

use std::sync::Arc;

use nalgebra::DMatrix;

use super::model::FbtModel;
use super::solver::{ConstraintRows, FbtParams, FbtSystem, IterOptions, MinimalSolution};
use crate::skin::dictionary::DictionaryChange;
use crate::solve::elastic_net::CoordinateDescentOptions;
use crate::{Error, Point, Result};

/// How the first transformations are found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum InitMethod {
    /// Eq. 22 (no L1 term).
    Linear,
    /// Eq. 23 with `β_sp = sparsity · max|β_lc XᵀY|`.
    Sparse { sparsity: f64 },
}

/// Iteration counts of the schedule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Schedule {
    pub init: InitMethod,
    /// Iterations of E_total (0 skips the stage).
    pub average_iters: usize,
    /// Iterations of E_mn in the main dictionary (0 skips it; then the
    /// average solution is final in the main dictionary).
    pub minimal_iters: usize,
    /// Iterations of E_mn in the rich dictionary (used only when the
    /// pipeline has one).
    pub rich_iters: usize,
    /// Relative energy decrease below which a stage stops early.
    pub rel_tol: f64,
}

impl Default for Schedule {
    fn default() -> Self {
        Schedule {
            init: InitMethod::Sparse { sparsity: 0.01 },
            average_iters: 5,
            minimal_iters: 5,
            rich_iters: 5,
            rel_tol: 1e-6,
        }
    }
}

/// Precomputation per (mesh set, dictionaries).
#[derive(Clone, Debug)]
pub struct FbtPipeline {
    init: Option<Arc<FbtModel>>,
    main: Arc<FbtModel>,
    rich: Option<Arc<FbtModel>>,
    to_main: Option<DictionaryChange>,
    to_rich: Option<DictionaryChange>,
}

impl FbtPipeline {
    /// Stages: optional init dictionary, main, optional rich; all over the
    /// same mesh set. Precomputes the Eq. 24 matrices.
    pub fn new(
        init: Option<Arc<FbtModel>>,
        main: Arc<FbtModel>,
        rich: Option<Arc<FbtModel>>,
    ) -> Result<Self> {
        let n = main.dictionary().n_vertices();
        for m in init.iter().chain(rich.iter()) {
            if m.dictionary().n_vertices() != n || m.n_examples() != main.n_examples() {
                return Err(Error::invalid(
                    "pipeline stages must share the mesh set (vertices and examples)",
                ));
            }
        }
        let to_main = init
            .as_ref()
            .map(|i| DictionaryChange::new(i.dictionary(), main.dictionary()))
            .transpose()?;
        let to_rich = rich
            .as_ref()
            .map(|r| DictionaryChange::new(main.dictionary(), r.dictionary()))
            .transpose()?;
        Ok(FbtPipeline {
            init,
            main,
            rich,
            to_main,
            to_rich,
        })
    }

    /// The main stage's model.
    pub fn main(&self) -> &Arc<FbtModel> {
        &self.main
    }

    /// The model of the last stage (rich if present, else main).
    pub fn last(&self) -> &Arc<FbtModel> {
        self.rich.as_ref().unwrap_or(&self.main)
    }

    /// Factorises every stage for the constraint rows `H`.
    pub fn systems(&self, rows: &ConstraintRows, params: &FbtParams) -> Result<PipelineSystems> {
        let mk = |m: &Arc<FbtModel>| FbtSystem::new(m.clone(), rows.clone(), *params);
        // The stages that iterate get the reduced form of their iterations
        // (FbtSystem::prepare); the initialisation stage only solves Eq. 22.
        let prepared = |m: &Arc<FbtModel>| {
            mk(m).map(|mut s| {
                s.prepare();
                s
            })
        };
        Ok(PipelineSystems {
            init: self.init.as_ref().map(mk).transpose()?,
            main: prepared(&self.main)?,
            rich: self.rich.as_ref().map(prepared).transpose()?,
            to_main: self.to_main.clone(),
            to_rich: self.to_rich.clone(),
        })
    }
}

/// The stage systems for one `H`.
#[derive(Clone, Debug)]
pub struct PipelineSystems {
    pub init: Option<FbtSystem>,
    pub main: FbtSystem,
    pub rich: Option<FbtSystem>,
    to_main: Option<DictionaryChange>,
    to_rich: Option<DictionaryChange>,
}

/// Result of [`PipelineSystems::solve`].
#[derive(Clone, Debug)]
pub struct Registration {
    /// Transformations in the last stage's dictionary.
    pub t: DMatrix<f64>,
    /// Deformed positions `D T`.
    pub positions: Vec<Point>,
    /// The example ℓ* selected by E_mn (0 when no E_mn stage ran).
    pub example: usize,
    /// Global scale of the final solution.
    pub alpha: f64,
    /// Final energy of the last stage (E_mn, or E_total if only it ran).
    pub energy: f64,
    /// The last E_mn solution (all examples), if an E_mn stage ran.
    pub minimal: Option<MinimalSolution>,
    /// Local/scale/global iterations over all stages.
    pub iterations: usize,
    /// Energy after every step, per stage (`"average"`, `"minimal"`,
    /// `"rich"`).
    pub stage_traces: Vec<(&'static str, Vec<f64>)>,
}

impl PipelineSystems {
    /// The last stage's system.
    pub fn last(&self) -> &FbtSystem {
        self.rich.as_ref().unwrap_or(&self.main)
    }

    /// Marks constraint rows unavailable / available in every stage
    /// (Cholesky up/downdates, Sec. 4.4).
    pub fn set_available(&mut self, rows: &[usize], available: bool) -> Result<()> {
        if let Some(s) = self.init.as_mut() {
            s.set_available(rows, available)?;
        }
        self.main.set_available(rows, available)?;
        if let Some(s) = self.rich.as_mut() {
            s.set_available(rows, available)?;
        }
        Ok(())
    }

    /// The initial transformations in the main dictionary (steps 1–2).
    pub fn initial(&self, y: &DMatrix<f64>, init: InitMethod) -> Result<DMatrix<f64>> {
        let (sys, change) = match (&self.init, &self.to_main) {
            (Some(s), Some(c)) => (s, Some(c)),
            _ => (&self.main, None),
        };
        let t = match init {
            InitMethod::Linear => sys.initial(y)?,
            InitMethod::Sparse { sparsity } => {
                sys.sparse_initial(y, sparsity, &CoordinateDescentOptions::default())?
                    .0
            }
        };
        match change {
            Some(c) => c.apply(&t),
            None => Ok(t),
        }
    }

    /// Runs the schedule for targets `y` (h × 3).
    pub fn solve(&self, y: &DMatrix<f64>, schedule: &Schedule) -> Result<Registration> {
        let t0 = self.initial(y, schedule.init)?;
        self.solve_from(y, &t0, schedule)
    }

    /// Steps 3–5 of the schedule from transformations `t0` in the main
    /// dictionary.
    pub fn solve_from(
        &self,
        y: &DMatrix<f64>,
        t0: &DMatrix<f64>,
        schedule: &Schedule,
    ) -> Result<Registration> {
        let opts = |n| IterOptions {
            max_iter: n,
            rel_tol: schedule.rel_tol,
        };
        let mut traces = Vec::new();
        let mut iterations = 0;
        let mut t = t0.clone();
        let mut alpha = None;
        let mut energy = f64::NAN;
        let mut example = 0;
        let mut minimal = None;
        if schedule.average_iters > 0 {
            let s = self
                .main
                .solve_average(y, &t, &opts(schedule.average_iters))?;
            iterations += s.iterations;
            traces.push(("average", s.trace.energies()));
            t = s.t;
            alpha = Some(s.alpha);
            energy = s.energy;
        }
        if schedule.minimal_iters > 0 {
            let s = self
                .main
                .solve_minimal(y, &t, alpha, &opts(schedule.minimal_iters))?;
            iterations += s
                .per_example
                .iter()
                .map(|e| e.iterations)
                .max()
                .unwrap_or(0);
            traces.push(("minimal", s.min_trace()));
            t = s.t().clone();
            alpha = Some(s.alpha());
            energy = s.energy();
            example = s.best;
            minimal = Some(s);
        }
        let mut final_sys = &self.main;
        if let (Some(rich), Some(change)) = (&self.rich, &self.to_rich) {
            t = change.apply(&t)?;
            final_sys = rich;
            if schedule.rich_iters > 0 {
                let s = rich.solve_minimal(y, &t, alpha, &opts(schedule.rich_iters))?;
                iterations += s
                    .per_example
                    .iter()
                    .map(|e| e.iterations)
                    .max()
                    .unwrap_or(0);
                traces.push(("rich", s.min_trace()));
                t = s.t().clone();
                alpha = Some(s.alpha());
                energy = s.energy();
                example = s.best;
                minimal = Some(s);
            }
        }
        let positions = final_sys.positions(&t)?;
        Ok(Registration {
            t,
            positions,
            example,
            alpha: alpha.unwrap_or(1.0),
            energy,
            minimal,
            iterations,
            stage_traces: traces,
        })
    }
}
