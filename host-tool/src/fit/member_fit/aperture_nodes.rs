//! The cone's nodes (weight and geometry) each thread keeps per reading, so that a
//! member averaged over a detector aperture evaluates the member alone.

use std::cell::RefCell;
use std::collections::HashMap;

use brdf_core::aperture::Aperture;
use brdf_core::geometry::Geometry;
use brdf_core::member_model::{MemberEval, MemberGradient, MemberModel};

use super::super::data::Observation;

/// The member `m` averaged over [`Aperture::for_reading`]'s aperture of half-angle `a`
/// degrees at reading `o`, with the averaged gradient into `grad` when given: what
/// [`Aperture::average`] and [`Aperture::average_with_gradient`] give, bit for bit,
/// from the nodes this thread keeps (see [`NodeCache`]). `None` where the average
/// fails.
pub(crate) fn averaged(
    a: f64,
    m: &MemberModel<f64>,
    o: &Observation,
    grad: Option<&mut MemberGradient<f64>>,
) -> Option<MemberEval<f64>> {
    let n = Aperture::reading_order(a, m, o.theta_i, o.theta_r);
    NODES.with(|cache| {
        let mut cache = cache.borrow_mut();
        let nodes = cache.nodes(a, n, o)?;
        Aperture::average_nodes(m, o.theta_i, nodes, grad).ok()
    })
}

/// Most nodes a thread keeps (72 bytes each: 19 MB); past it the cache starts again.
/// A sweep's readings of the core take 48 x 48 nodes each at the most, its other
/// readings a few dozen (the solar array's default fit keeps about half of this, by
/// the process's peak memory).
const KEPT_NODES: usize = 1 << 18;

/// One node of an aperture at a reading: its weight and the geometry of its direction
/// ([`Aperture::nodes_at`]).
type Node = (f64, Geometry<f64>);

/// The nodes of the apertures this thread has averaged over, by half-angle, reading
/// and order: a node's direction and geometry (three square roots, an atan2) depend on
/// the reading alone, and an aperture fit averages every reading at each of its LM
/// passes, for every member; built at every average, they were a third of the solar
/// array's default fit. The Gauss–Legendre nodes of each order are kept too
/// (computed by Newton's method, they cost about as much as an average at 48 nodes).
#[derive(Default)]
struct NodeCache {
    /// By (half-angle, theta_i, theta_r) bits and order.
    nodes: HashMap<(u64, u64, u64, usize), Vec<Node>>,
    /// Nodes held in `nodes`.
    held: usize,
    /// The apertures built, by order (index n - 1), each for the half-angle it was
    /// last built for.
    apertures: Vec<Option<Aperture<f64>>>,
}

impl NodeCache {
    /// The nodes of the aperture of half-angle `a` degrees and order `n` at reading `o`,
    /// built on first use; `None` when they cannot be built.
    fn nodes(&mut self, a: f64, n: usize, o: &Observation) -> Option<&[Node]> {
        let key = (a.to_bits(), o.theta_i.to_bits(), o.theta_r.to_bits(), n);
        if !self.nodes.contains_key(&key) {
            if self.apertures.len() < n {
                self.apertures.resize(n, None);
            }
            let slot = &mut self.apertures[n - 1];
            if slot
                .as_ref()
                .is_none_or(|ap| ap.half_angle_deg().to_bits() != a.to_bits())
            {
                *slot = Some(Aperture::new(a, n, n).ok()?);
            }
            let mut list = Vec::with_capacity(n * n);
            // theta_r always: the nodes serve every member, with and without the
            // directional term.
            slot.as_ref()?
                .nodes_at(o.theta_i, o.theta_r, true, |w, g| list.push((w, g)))
                .ok()?;
            if self.held + list.len() > KEPT_NODES {
                self.nodes.clear();
                self.held = 0;
            }
            self.held += list.len();
            self.nodes.insert(key, list);
        }
        self.nodes.get(&key).map(Vec::as_slice)
    }
}

thread_local! {
    static NODES: RefCell<NodeCache> = RefCell::new(NodeCache::default());
}
