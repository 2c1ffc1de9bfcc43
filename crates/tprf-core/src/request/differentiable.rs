//! A differentiable render: [`Differentiable::forward`] renders the request's cube at
//! given parameter values, [`Differentiable::backward`] the vector-Jacobian product
//! `dL/dtheta` of `L = sum(weights x cube)` at the last forward's values
//! ([`crate::transport::derivative`] says how).
//!
//! The time axis is fixed once (the request's `t0` and `dt`, or the window a pilot
//! render of the scene as loaded chooses), so every forward's cube has the shape of the
//! weights. Sampling is made independent of the parameters, so that forward renders
//! at nearby values use common random numbers (finite differences agree sample by
//! sample): uniform sampling (no adaptive plan) and, where the request leaves them
//! automatic, no first-vertex split and no light vertices (a pilot would choose them
//! anew at each value). The forward and backward take their own seeds: with the same
//! seed, their noise is correlated and `L`'s gradient through a loss of the forward
//! cube is biased.

use super::parameter::{ParameterError, Target};
use super::{Observer, RenderRequest, RequestError, Session, cube_metadata};
use crate::export::CubeMetadata;
use crate::film::{TimeAxis, TprfFilm};
use crate::scene::{self, Scene};
use crate::transport::Renderer;
use crate::transport::derivative::{MAX_WRT, VjpError, VjpTarget, Wrt};
use std::ops::ControlFlow;
use std::sync::Arc;
use std::time::Instant;

/// Why a differentiable render cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum DifferentiableError {
    #[error(transparent)]
    Parameter(#[from] ParameterError),
    #[error(transparent)]
    Request(#[from] RequestError),
    #[error(transparent)]
    Vjp(#[from] VjpError),
    #[error("wrt: {0}")]
    Wrt(String),
    #[error("{0:?} is not among the parameters differentiated (wrt: {1})")]
    NotInWrt(String, String),
    #[error("backward needs a forward render first (its values are the point differentiated at)")]
    NoForward,
    #[error("the render request needs `spp` (a fixed sample count) for a derivative render")]
    NoSpp,
    #[error("interrupted")]
    Interrupted,
}

/// A render request differentiable with respect to named parameters.
pub struct Differentiable {
    request: RenderRequest,
    /// The scene as loaded (the request's medium applied by each session).
    scene: Arc<Scene>,
    names: Vec<String>,
    targets: Vec<Target>,
    /// The values of the next forward (the scene's own until one sets them).
    values: Vec<f64>,
    axis: TimeAxis,
    /// The renderer of the last forward, and the values it was made at.
    last: Option<(Arc<Renderer>, Vec<f64>)>,
}

/// The cube of one forward render.
pub struct Forward {
    pub film: TprfFilm,
    pub meta: CubeMetadata,
}

impl Differentiable {
    /// `request` (its scene loaded) differentiable with respect to `wrt`.
    pub fn new(
        request: &RenderRequest,
        wrt: &[String],
    ) -> Result<Differentiable, DifferentiableError> {
        request.validate()?;
        let scene = scene::load(&request.scene).map_err(RequestError::from)?;
        Differentiable::with_scene(request, Arc::new(scene), wrt)
    }

    /// [`Differentiable::new`] on a scene built in code.
    pub fn with_scene(
        request: &RenderRequest,
        scene: Arc<Scene>,
        wrt: &[String],
    ) -> Result<Differentiable, DifferentiableError> {
        if wrt.is_empty() {
            return Err(DifferentiableError::Wrt("no parameter named".into()));
        }
        // Refused up front, not after a forward render: the derivative walk has no
        // re-emission.
        if let Some(m) = scene.materials.iter().find(|m| m.luminescence.is_some()) {
            return Err(VjpError::Luminescent(m.name.clone()).into());
        }
        if wrt.len() > MAX_WRT {
            return Err(VjpError::TooMany(wrt.len()).into());
        }
        let mut targets = Vec::with_capacity(wrt.len());
        for (i, name) in wrt.iter().enumerate() {
            if wrt[..i].contains(name) {
                return Err(DifferentiableError::Wrt(format!("{name:?} is named twice")));
            }
            let t = Target::parse(name, &scene)?;
            if t.wrt(0.0).is_none() {
                return Err(ParameterError::Refused {
                    name: name.clone(),
                    why: "the media walk carries no derivatives yet (docs/gradients.md)".into(),
                }
                .into());
            }
            targets.push(t);
        }
        if request.spp_target().is_none() || request.spp.is_none() {
            return Err(DifferentiableError::NoSpp);
        }
        let mut request = RenderRequest {
            uniform: true,
            splits: Some(request.splits.unwrap_or(1)),
            light_vertex: Some(request.light_vertex.unwrap_or(false)),
            shard: None,
            ..request.clone()
        };
        let pick = |c| request.channel.pick(c);
        let values = targets.iter().map(|t| t.value(&scene, pick)).collect();
        // The window, fixed for every forward: the request's, or the pilot's at the
        // scene's own values.
        let session = request
            .thread_pool()?
            .install(|| Session::with_scene(&request, scene.clone()))?;
        let axis = session.axis();
        request.t0_s = Some(axis.t0_s);
        request.dt_s = Some(axis.dt_s);
        Ok(Differentiable {
            request,
            scene,
            names: wrt.to_vec(),
            targets,
            values,
            axis,
            last: None,
        })
    }

    /// The parameters' names, in the order of [`Differentiable::backward`]'s values.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// The values the next forward renders at (the last set, else the scene's own).
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// The time axis of every cube.
    pub fn axis(&self) -> TimeAxis {
        self.axis
    }

    /// The request rendered (its window fixed, its sampling made independent of the
    /// parameters).
    pub fn request(&self) -> &RenderRequest {
        &self.request
    }

    /// Set the values of named parameters for the next forward (the others keep theirs);
    /// each checked for its range.
    pub fn set_values(&mut self, values: &[(String, f64)]) -> Result<(), DifferentiableError> {
        let mut next = self.values.clone();
        for (name, v) in values {
            let Some(k) = self.names.iter().position(|n| n == name) else {
                return Err(DifferentiableError::NotInWrt(
                    name.clone(),
                    self.names.join(", "),
                ));
            };
            // Checked against a copy: nothing is set if one value is refused.
            let mut probe = (*self.scene).clone();
            self.targets[k].set(&mut probe, *v, name)?;
            next[k] = *v;
        }
        self.values = next;
        Ok(())
    }

    /// The scene at the current values.
    fn scene_now(&self) -> Result<Scene, DifferentiableError> {
        let mut scene = (*self.scene).clone();
        for ((t, v), name) in self.targets.iter().zip(&self.values).zip(&self.names) {
            t.set(&mut scene, *v, name)?;
        }
        Ok(scene)
    }

    /// Render the cube at `values` (set as [`Differentiable::set_values`] does) with
    /// `seed`, each pass reported to `observer` (which may stop it:
    /// [`DifferentiableError::Interrupted`]).
    pub fn forward(
        &mut self,
        values: &[(String, f64)],
        seed: u64,
        observer: &mut (dyn Observer + Send),
    ) -> Result<Forward, DifferentiableError> {
        self.set_values(values)?;
        let start = Instant::now();
        let scene = Arc::new(self.scene_now()?);
        let request = RenderRequest {
            seed,
            ..self.request.clone()
        };
        let pool = request.thread_pool()?;
        let threads = pool.current_num_threads();
        pool.install(|| {
            let mut session = Session::with_scene(&request, scene)?;
            let mut stopped = false;
            let reports = session.run(|r, film| {
                let flow = observer.pass(r, film);
                stopped |= flow.is_break();
                flow
            });
            if stopped {
                return Err(DifferentiableError::Interrupted);
            }
            if let Some(r) = reports.last()
                && r.left_out.non_finite > 0
            {
                return Err(RequestError::NonFinite {
                    non_finite: r.left_out.non_finite,
                    paths: r.paths,
                    scene: request.scene.clone(),
                }
                .into());
            }
            let meta = cube_metadata(
                &session,
                threads,
                start.elapsed().as_secs_f64(),
                std::slice::from_ref(&reports),
            )?;
            self.last = Some((session.shared_renderer(), self.values.clone()));
            Ok(Forward {
                film: session.into_film(),
                meta,
            })
        })
    }

    /// `dL/dtheta` for `L = sum(weights x cube)` at the last forward's values, one per
    /// parameter in [`Differentiable::names`]' order, from a derivative render of the
    /// request's spp with `seed`. `weights` is `[height, width, bins]`, row-major.
    /// `progress(done_spp, total_spp)` is called between chunks of samples and may stop
    /// the render ([`DifferentiableError::Interrupted`]).
    pub fn backward(
        &self,
        weights: &[f32],
        seed: u64,
        mut progress: impl FnMut(u64, u64) -> ControlFlow<()> + Send,
    ) -> Result<Vec<f64>, DifferentiableError> {
        let Some((renderer, values)) = &self.last else {
            return Err(DifferentiableError::NoForward);
        };
        let wrt: Vec<Wrt> = self
            .targets
            .iter()
            .zip(values)
            .filter_map(|(t, &v)| t.wrt(v))
            .collect();
        let target = VjpTarget {
            weights,
            width: self.request.width,
            height: self.request.height,
            axis: self.axis,
            filter: self.request.time_filter,
        };
        let spp = self.request.spp.ok_or(DifferentiableError::NoSpp)?;
        // Chunks of samples, so that progress and Ctrl-C are seen while it runs.
        let chunk = spp.div_ceil(16).clamp(1, u32::MAX as u64);
        let pool = self.request.thread_pool()?;
        pool.install(|| {
            let mut sum = vec![0.0f64; wrt.len()];
            let mut done = 0u64;
            while done < spp {
                let n = chunk.min(spp - done) as u32;
                let part = renderer.vjp(&wrt, &target, seed, done, n)?;
                for (s, p) in sum.iter_mut().zip(part) {
                    *s += p;
                }
                done += n as u64;
                if progress(done, spp).is_break() && done < spp {
                    return Err(DifferentiableError::Interrupted);
                }
            }
            Ok(sum.into_iter().map(|s| s / spp as f64).collect())
        })
    }
}
