//! The numbering of the moving-frame unknowns of a [`Mechanism`] ([`number`]): which unknowns
//! each node of each link has, with the pins eliminated, and which each slider has; the terms each
//! link carries ([`link_terms`]) and the half-bandwidth ([`bandwidth`]) that follow.
//!
//! Ideal pins are eliminated, not enforced: the translations of the nodes a pin joins (through
//! any chain of pins) are one group, found by union-find over every node translation, every
//! slider and ground (rigid bodies and two-direction supports are ground). A group that holds
//! ground has no translation unknown ([`Trans::Fixed`]); a group on a slider has the slider's one
//! unknown along its guide ([`Trans::Slider`]); a group of two or more nodes has one shared pair
//! in global axes ([`Trans::Global`], numbered once, at its first node); a node alone keeps its
//! pair in its link's axes, without the components a one-direction support holds
//! ([`Trans::Local`]). Rotations are never shared (a pin is a revolute joint): each node has its
//! own unless a support holds it. Unknowns are numbered in link/node order (translation, then
//! rotation); a slider reached only through a clearance joint (no pin) gets its unknown right
//! after the journal node's, for a narrow band, and a slider attached to nothing keeps none (it
//! moves along its nominal path).
//!
//! A rigid link ([`Link::rigid`](crate::model::mechanism::Link::rigid)) has node 0's unknowns
//! only: its node 1 takes node 0's translation and rotation ([`NodeMap::lever`] = its length: the
//! local state `[u0, v0 + L theta, theta]`). Its node 1 pinned or supported closes a loop: allowed
//! when node 0 is held (on ground, possibly through other such links), and then the link has no
//! rotation unknown, node 1 joins ground, and a slider pinned to it keeps no unknown (it moves on
//! its nominal path); a mechanism with a rigid link may so have no unknown at all (it follows its
//! nominal motion).
//!
//! Refused as [`Error::InvalidModel`] (messages as below, names quoted):
//! - node 1 of a rigid link pinned or supported while its node 0 is free: `node 1 of rigid link
//!   "r" is pinned or supported while its node 0 is free to move: not supported (...)`;
//! - a slider pinned, through its links, to ground or a rigid body: `slider "s" is pinned, through
//!   its links, to ground or a rigid body: over-constrained`;
//! - two sliders pinned to one point: `sliders "a" and "b" are pinned to the same point:
//!   over-constrained`;
//! - a node on a slider with a one-direction support: `node 3 of link "l" has a support and is on
//!   slider "s": over-constrained`;
//! - a pinned node with a one-direction support: `node 3 of link "l" has a one-direction support
//!   and is pinned to another link: not supported (over-constrained in general)`;
//! - nothing left to solve for (and no rigid link): `the mechanism has no free elastic degree of
//!   freedom`.

use crate::error::{Error, Result};
use crate::model::mechanism::{Endpoint, Mechanism};

/// The index of an unknown that does not exist (a component held at zero).
pub const NONE: usize = usize::MAX;

/// How the translation of a node enters the unknowns.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Trans {
    /// Local unknowns (NONE where a support holds the component).
    Local([usize; 2]),
    /// Shared unknowns in global axes.
    Global([usize; 2]),
    /// One unknown along the guide of slider `slider`.
    Slider {
        /// The unknown.
        s: usize,
        /// Index into [`Mechanism::sliders`].
        slider: usize,
    },
    /// Held at zero.
    Fixed,
}

/// The unknowns of one node: its translation and its rotation ([`NONE`] where a support holds
/// it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeMap {
    /// The translation.
    pub trans: Trans,
    /// The rotation unknown, or [`NONE`].
    pub rot: usize,
    /// Node 1 of a rigid link: its distance from node 0 along the link, m (its local state is
    /// node 0's translation and rotation, `[u0, v0 + lever theta, theta]`); 0 for every other
    /// node.
    pub lever: f64,
}

/// The numbering of a mechanism's unknowns ([`number`]).
#[derive(Debug, Clone, PartialEq)]
pub struct DofMap {
    /// Per link, per node, its unknowns.
    pub nodes: Vec<Vec<NodeMap>>,
    /// Per slider, its unknown along the guide, or [`NONE`] (attached to nothing).
    pub slider_dof: Vec<usize>,
    /// The number of unknowns (> 0).
    pub n: usize,
    /// Per unknown: whether it is a displacement in metres (nodal translations, slider travel),
    /// rather than a rotation.
    pub translational: Vec<bool>,
}

/// The terms a link carries on the moving-frame steppers (docs/method.md section 2), resolved from
/// its [`Terms`](crate::model::mechanism::Terms) (`None` = automatic) and the mechanism.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LinkTerms {
    /// Coriolis `M_COR` (automatic: the frame rotates).
    pub coriolis: bool,
    /// Inertia coupling `M_IC` (automatic: the frame rotates).
    pub coupling: bool,
    /// Geometric `K2`, `K3`, `D2` (automatic: the frame rotates or a nodal load has an axial
    /// component).
    pub geometric: bool,
    /// Inertia load of the nominal motion `M_R a_R` (automatic: the frame moves, or gravity).
    pub load: bool,
    /// A node's translation is in global axes or on a slider (the frame's rotation transforms
    /// it): not a term one asks for, a consequence of the numbering.
    pub transformed: bool,
}

/// The terms each link of `mech` carries, given its numbering `nodes` ([`DofMap::nodes`]).
pub fn link_terms(mech: &Mechanism, nodes: &[Vec<NodeMap>]) -> Vec<LinkTerms> {
    let gravity = mech.gravity != [0.0, 0.0];
    (mech.links.iter().enumerate().zip(nodes))
        .map(|((li, l), nodes)| {
            let rotates = l.frame.rotates();
            let moves = rotates || l.frame.translates();
            let axially_loaded = mech.loads.iter().any(|f| f.link == li && f.force[0] != 0.0);
            let t = l.terms;
            LinkTerms {
                coriolis: t.coriolis.unwrap_or(rotates),
                coupling: t.inertia_coupling.unwrap_or(rotates),
                geometric: l.rigid.is_none() && t.geometric.unwrap_or(rotates || axially_loaded),
                load: t.inertia_load.unwrap_or(moves || gravity),
                transformed: nodes
                    .iter()
                    .any(|n| matches!(n.trans, Trans::Global(_) | Trans::Slider { .. })),
            }
        })
        .collect()
}

/// The half-bandwidth of the moving-frame matrices of `mech` numbered as `nodes` and
/// `slider_dof` ([`DofMap`]): the largest distance between two unknowns an element (its two
/// nodes' translations and rotations) or a clearance joint (its two sides' translations) couples.
pub fn bandwidth(mech: &Mechanism, nodes: &[Vec<NodeMap>], slider_dof: &[usize]) -> usize {
    let mut b = 0usize;
    let mut couple = |ids: &[usize]| {
        for &i in ids.iter().filter(|&&i| i != NONE) {
            for &j in ids.iter().filter(|&&j| j != NONE) {
                b = b.max(i.abs_diff(j));
            }
        }
    };
    let slots = |m: &NodeMap| -> [usize; 3] {
        match m.trans {
            Trans::Local(ix) | Trans::Global(ix) => [ix[0], ix[1], m.rot],
            Trans::Slider { s, .. } => [s, NONE, m.rot],
            Trans::Fixed => [NONE, NONE, m.rot],
        }
    };
    for link in nodes {
        for w in link.windows(2) {
            let (a, c) = (slots(&w[0]), slots(&w[1]));
            couple(&[a[0], a[1], a[2], c[0], c[1], c[2]]);
        }
    }
    let ep_slots = |e: &Endpoint| -> [usize; 3] {
        match e {
            Endpoint::Node { link, node } => slots(&nodes[*link][*node]),
            Endpoint::Body { .. } => [NONE; 3],
            Endpoint::Slider(s) => [slider_dof[*s], NONE, NONE],
        }
    };
    // a clearance joint couples its sides' translations, and the rotation of a rigid link's
    // node 1 (its translation turns with it)
    let lever_rot = |e: &Endpoint| match e {
        Endpoint::Node { link, node } if nodes[*link][*node].lever != 0.0 => nodes[*link][*node].rot,
        _ => NONE,
    };
    for j in &mech.joints {
        let (a, c) = (ep_slots(&j.journal), ep_slots(&j.bearing));
        if j.friction.is_some() {
            // the friction moment couples both sides' rotations too
            couple(&[
                a[0],
                a[1],
                a[2],
                lever_rot(&j.journal),
                c[0],
                c[1],
                c[2],
                lever_rot(&j.bearing),
            ]);
        } else {
            couple(&[a[0], a[1], lever_rot(&j.journal), c[0], c[1], lever_rot(&j.bearing)]);
        }
    }
    b
}

/// A slider reached only through a clearance joint at node `nd` of link `li` gets its unknown
/// next to the journal's, for a narrow band (unless a rigid loop holds it).
fn number_joint_sliders(
    mech: &Mechanism,
    li: usize,
    nd: usize,
    held: &[bool],
    slider_dof: &mut [usize],
    next: &mut usize,
) {
    for j in &mech.joints {
        if let (Endpoint::Node { link, node }, Endpoint::Slider(s)) = (&j.journal, &j.bearing) {
            if *link == li && *node == nd && slider_dof[*s] == NONE && !held[*s] {
                slider_dof[*s] = *next;
                *next += 1;
            }
        }
    }
}

struct DofBuilder {
    parent: Vec<usize>,
}

impl DofBuilder {
    fn find(&mut self, mut i: usize) -> usize {
        while self.parent[i] != i {
            self.parent[i] = self.parent[self.parent[i]];
            i = self.parent[i];
        }
        i
    }
    fn union(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            self.parent[ra.max(rb)] = ra.min(rb);
        }
    }
}

/// Numbers the unknowns of `mech` (the rules of the module doc), pins eliminated. `mech` must
/// have passed [`Mechanism::validate`] (its references in range). Fails with
/// [`Error::InvalidModel`] for an over-constrained node or slider, or no unknown at all (the
/// messages of the module doc).
pub fn number(mech: &Mechanism) -> Result<DofMap> {
    // Union-find over node translations, sliders and ground.
    let offs: Vec<usize> = mech
        .links
        .iter()
        .scan(0, |acc, l| {
            let o = *acc;
            *acc += l.nodes();
            Some(o)
        })
        .collect();
    let total_nodes: usize = mech.links.iter().map(|l| l.nodes()).sum();
    let ground = total_nodes + mech.sliders.len();
    let mut uf = DofBuilder {
        parent: (0..=ground).collect(),
    };
    let item = |e: &Endpoint| match e {
        Endpoint::Node { link, node } => offs[*link] + node,
        Endpoint::Body { .. } => ground,
        Endpoint::Slider(s) => total_nodes + s,
    };
    for p in &mech.pins {
        uf.union(item(&p.a), item(&p.b));
    }
    let mut rollers = vec![[false; 3]; total_nodes];
    for s in &mech.supports {
        let i = offs[s.link] + s.node;
        if s.fixed[0] && s.fixed[1] {
            uf.union(i, ground);
        }
        for k in 0..3 {
            rollers[i][k] |= s.fixed[k];
        }
    }
    // A slider pinned, through its links, to ground: over-constrained (before the rigid links
    // close any loop).
    for s in 0..mech.sliders.len() {
        if uf.find(total_nodes + s) == uf.find(ground) {
            return Err(Error::InvalidModel {
                message: format!(
                    "slider {:?} is pinned, through its links, to ground or a rigid body: over-constrained",
                    mech.sliders[s].name
                ),
            });
        }
    }
    // Rigid links: node 1 follows node 0 and the link's rotation. Node 1 pinned or supported
    // closes a loop: allowed when node 0 is held (on ground, possibly through other such
    // links), and then the whole link is held (no rotation unknown) and node 1 joins ground
    // with whatever is pinned to it (the slider-crank of rigid bodies with ideal joints).
    let attached = |li: usize, nd: usize| {
        let on = |e: &Endpoint| matches!(e, Endpoint::Node { link, node } if *link == li && *node == nd);
        mech.pins.iter().any(|p| on(&p.a) || on(&p.b))
            || mech
                .supports
                .iter()
                .any(|s| s.link == li && s.node == nd && s.fixed.iter().any(|&f| f))
    };
    let mut held = vec![false; mech.links.len()];
    loop {
        let mut changed = false;
        for (li, l) in mech.links.iter().enumerate() {
            if l.rigid.is_some() && !held[li] && attached(li, 1) && uf.find(offs[li]) == uf.find(ground) {
                uf.union(offs[li] + 1, ground);
                held[li] = true;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    if let Some(l) = (mech.links.iter().enumerate()).find(|(li, l)| l.rigid.is_some() && !held[*li] && attached(*li, 1))
    {
        return Err(Error::InvalidModel {
            message: format!(
                "node 1 of rigid link {:?} is pinned or supported while its node 0 is free to move: not supported (a rigid link is held by its node 0; attach its node 1 by a clearance joint, or hold node 0)",
                l.1.name
            ),
        });
    }
    // Classify groups.
    let root_ground = uf.find(ground);
    let mut group_slider: Vec<Option<usize>> = vec![None; ground + 1];
    let mut group_size = vec![0usize; ground + 1];
    for i in 0..total_nodes {
        let r = uf.find(i);
        group_size[r] += 1;
    }
    // a slider on a node that a held rigid link holds keeps no unknown (it moves on its path)
    let mut held_slider = vec![false; mech.sliders.len()];
    for s in 0..mech.sliders.len() {
        let r = uf.find(total_nodes + s);
        if r == root_ground {
            held_slider[s] = true;
            continue;
        }
        if let Some(o) = group_slider[r] {
            return Err(Error::InvalidModel {
                message: format!(
                    "sliders {:?} and {:?} are pinned to the same point: over-constrained",
                    mech.sliders[o].name, mech.sliders[s].name
                ),
            });
        }
        group_slider[r] = Some(s);
    }
    // Number the unknowns in link/node order; a flexible link whose last node only is attached
    // to an earlier link (the rocker of a four-bar, held at ground by its first node) from its
    // last node back, so that the loop closes next to the unknowns it closes on (a narrow band).
    let mut touches_earlier = |li: usize, nd: usize| {
        // pinned (not through ground) to a node of an earlier link, or joined to one
        let r = uf.find(offs[li] + nd);
        let pinned = r != uf.find(ground) && (0..offs[li]).any(|i| uf.find(i) == r);
        let on = |e: &Endpoint| matches!(e, Endpoint::Node { link, node } if *link == li && *node == nd);
        let earlier = |e: &Endpoint| matches!(e, Endpoint::Node { link, .. } if *link < li);
        pinned
            || mech
                .joints
                .iter()
                .any(|j| (on(&j.journal) && earlier(&j.bearing)) || (on(&j.bearing) && earlier(&j.journal)))
    };
    let reversed: Vec<bool> = (mech.links.iter().enumerate())
        .map(|(li, l)| {
            let last = l.nodes() - 1;
            l.rigid.is_none() && last > 0 && touches_earlier(li, last) && !touches_earlier(li, 0)
        })
        .collect();
    let mut next = 0usize;
    let mut group_dofs: Vec<Option<[usize; 2]>> = vec![None; ground + 1];
    let mut slider_dof = vec![NONE; mech.sliders.len()];
    let mut links = Vec::with_capacity(mech.links.len());
    for (li, l) in mech.links.iter().enumerate() {
        let unset = NodeMap {
            trans: Trans::Fixed,
            rot: NONE,
            lever: 0.0,
        };
        let mut nodes: Vec<NodeMap> = vec![unset; l.nodes()];
        let order: Vec<usize> = if reversed[li] {
            (0..l.nodes()).rev().collect()
        } else {
            (0..l.nodes()).collect()
        };
        for nd in order {
            let i = offs[li] + nd;
            if nd == 1 && l.rigid.is_some() {
                // node 1 of a rigid link: node 0's unknowns, its translation turned by theta
                let n0 = nodes[0];
                nodes[1] = NodeMap {
                    trans: if held[li] { Trans::Fixed } else { n0.trans },
                    rot: n0.rot,
                    lever: l.section.length,
                };
                number_joint_sliders(mech, li, nd, &held_slider, &mut slider_dof, &mut next);
                continue;
            }
            let r = uf.find(i);
            let partial = (rollers[i][0] || rollers[i][1]) && !(rollers[i][0] && rollers[i][1]);
            let trans = if r == root_ground {
                Trans::Fixed
            } else if let Some(s) = group_slider[r] {
                if partial {
                    return Err(Error::InvalidModel {
                        message: format!(
                            "node {nd} of link {:?} has a support and is on slider {:?}: over-constrained",
                            l.name, mech.sliders[s].name
                        ),
                    });
                }
                if slider_dof[s] == NONE {
                    slider_dof[s] = next;
                    next += 1;
                }
                Trans::Slider {
                    s: slider_dof[s],
                    slider: s,
                }
            } else if group_size[r] > 1 {
                if partial {
                    return Err(Error::InvalidModel {
                        message: format!(
                            "node {nd} of link {:?} has a one-direction support and is pinned to another link: not supported (over-constrained in general)",
                            l.name
                        ),
                    });
                }
                let d = *group_dofs[r].get_or_insert_with(|| {
                    next += 2;
                    [next - 2, next - 1]
                });
                Trans::Global(d)
            } else {
                let mut ix = [NONE; 2];
                for k in 0..2 {
                    if !rollers[i][k] {
                        ix[k] = next;
                        next += 1;
                    }
                }
                Trans::Local(ix)
            };
            let rot = if rollers[i][2] || held[li] {
                NONE
            } else {
                next += 1;
                next - 1
            };
            nodes[nd] = NodeMap { trans, rot, lever: 0.0 };
            number_joint_sliders(mech, li, nd, &held_slider, &mut slider_dof, &mut next);
        }
        links.push(nodes);
    }
    // A slider attached to nothing keeps no unknown: it moves along its nominal path.
    let n = next;
    // a mechanism of rigid bodies with ideal joints may have nothing to solve for: it follows
    // its nominal motion
    if n == 0 && !mech.links.iter().any(|l| l.rigid.is_some()) {
        return Err(Error::InvalidModel {
            message: "the mechanism has no free elastic degree of freedom".into(),
        });
    }
    let mut translational = vec![true; n];
    for nodes in &links {
        for m in nodes {
            if m.rot != NONE {
                translational[m.rot] = false;
            }
        }
    }
    Ok(DofMap {
        nodes: links,
        slider_dof,
        n,
        translational,
    })
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::contact::{DampingLaw, SpringDamper};
    use crate::kinematics::{FrameKinematics, RotatingFrame, Rotation};
    use crate::model::mechanism::{Clearance, Link, Pin, Slider, Support};
    use crate::model::section::BeamSection;
    use crate::model::Motion;
    use crate::plan::{Plan, StepperKind};
    use crate::run::Settings;

    fn frame(rotation: Rotation) -> Arc<dyn FrameKinematics> {
        Arc::new(RotatingFrame::new(Motion::Fixed { position: [0.0, 0.0] }, rotation).unwrap())
    }

    fn link(name: &str, elements: usize) -> Link {
        Link::new(
            name,
            BeamSection {
                length: 0.1 * elements as f64,
                elements,
                youngs_modulus: 2e11,
                density: 7850.0,
                damping: 0.0,
                area: 1e-4,
                inertia: 1e-9,
            },
            frame(Rotation::Fixed { angle: 0.0 }),
        )
    }

    fn node(link: usize, node: usize) -> Endpoint {
        Endpoint::Node { link, node }
    }

    fn ground() -> Endpoint {
        Endpoint::Body {
            frame: frame(Rotation::Fixed { angle: 0.0 }),
            point: [0.0, 0.0],
            name: "ground".into(),
        }
    }

    fn pin(name: &str, a: Endpoint, b: Endpoint) -> Pin {
        Pin {
            name: name.into(),
            a,
            b,
        }
    }

    fn slider(name: &str) -> Slider {
        Slider {
            name: name.into(),
            mass: 0.1,
            angle: 0.0,
            path: frame(Rotation::Fixed { angle: 0.0 }),
        }
    }

    fn bearing() -> Arc<SpringDamper> {
        Arc::new(SpringDamper {
            stiffness: 1e8,
            damping: 0.0,
            damping_law: DampingLaw::Viscous,
            no_tension: false,
        })
    }

    fn clamp(link: usize, node: usize) -> Support {
        Support {
            link,
            node,
            fixed: [true; 3],
        }
    }

    fn local(ix: [usize; 2], rot: usize) -> NodeMap {
        NodeMap {
            trans: Trans::Local(ix),
            rot,
            lever: 0.0,
        }
    }

    fn global(ix: [usize; 2], rot: usize) -> NodeMap {
        NodeMap {
            trans: Trans::Global(ix),
            rot,
            lever: 0.0,
        }
    }

    fn fixed(rot: usize) -> NodeMap {
        NodeMap {
            trans: Trans::Fixed,
            rot,
            lever: 0.0,
        }
    }

    fn message(mech: &Mechanism) -> String {
        match number(mech) {
            Err(Error::InvalidModel { message }) => message,
            other => panic!("expected an over-constrained model, got {other:?}"),
        }
    }

    /// Crank (2 elements), coupler (3), rocker (2), pinned to ground at the crank's and rocker's
    /// first nodes and to each other: the two pinned groups are one global pair each, numbered at
    /// their first node and shared; the ground pins fix the translations, never the rotations.
    /// The rocker, held at ground by its first node and pinned to the coupler by its last, is
    /// numbered from its last node: its unknowns follow the coupler's end (half-bandwidth 6; 7
    /// numbered from its first node, and 19 for the four-bar scene's 6-element rocker).
    #[test]
    fn a_pinned_chain_numbers_each_shared_pair_once() {
        let mech = Mechanism {
            links: vec![link("crank", 2), link("coupler", 3), link("rocker", 2)],
            pins: vec![
                pin("O2", node(0, 0), ground()),
                pin("A", node(0, 2), node(1, 0)),
                pin("B", node(1, 3), node(2, 2)),
                pin("O4", node(2, 0), ground()),
            ],
            ..Default::default()
        };
        let map = number(&mech).unwrap();
        let expected = vec![
            vec![fixed(0), local([1, 2], 3), global([4, 5], 6)],
            vec![
                global([4, 5], 7),
                local([8, 9], 10),
                local([11, 12], 13),
                global([14, 15], 16),
            ],
            vec![fixed(21), local([18, 19], 20), global([14, 15], 17)],
        ];
        assert_eq!(map.nodes, expected);
        assert_eq!(bandwidth(&mech, &map.nodes, &map.slider_dof), 6);
        assert_eq!(map.n, 22);
        assert!(map.slider_dof.is_empty());
        let rotations = [0, 3, 6, 7, 10, 13, 16, 17, 20, 21];
        for (i, &t) in map.translational.iter().enumerate() {
            assert_eq!(t, !rotations.contains(&i), "unknown {i}");
        }
    }

    /// A slider that only a clearance joint reaches takes the unknown right after its journal
    /// node's (not at the end); a slider pinned to a node is that node's translation; a slider
    /// attached to nothing has none.
    #[test]
    fn a_slider_reached_through_a_clearance_joint_is_numbered_next_to_its_journal() {
        let mech = Mechanism {
            links: vec![link("arm", 2), link("rod", 1)],
            sliders: vec![slider("free"), slider("pinned"), slider("loose")],
            supports: vec![clamp(0, 0), clamp(1, 0)],
            pins: vec![pin("P", node(1, 1), Endpoint::Slider(1))],
            joints: vec![Clearance {
                friction: None,
                name: "J".into(),
                journal: node(0, 1),
                bearing: Endpoint::Slider(0),
                clearance: 1e-4,
                law: bearing(),
            }],
            ..Default::default()
        };
        let map = number(&mech).unwrap();
        let on_slider = NodeMap {
            trans: Trans::Slider { s: 7, slider: 1 },
            rot: 8,
            lever: 0.0,
        };
        assert_eq!(
            map.nodes,
            vec![
                vec![fixed(NONE), local([0, 1], 2), local([4, 5], 6)],
                vec![fixed(NONE), on_slider]
            ]
        );
        assert_eq!(map.slider_dof, vec![3, 7, NONE]);
        assert_eq!(map.n, 9);
        assert_eq!(
            map.translational,
            vec![true, true, false, true, true, true, false, true, false]
        );
    }

    #[test]
    fn over_constrained_models_are_refused_with_their_messages() {
        let two = || Mechanism {
            links: vec![link("a", 2), link("b", 2)],
            supports: vec![clamp(1, 0)],
            ..Default::default()
        };
        // a slider pinned, through link "a", to ground
        let mut m = two();
        m.sliders.push(slider("s"));
        m.pins = vec![
            pin("P", node(0, 2), Endpoint::Slider(0)),
            pin("G", node(0, 2), ground()),
        ];
        assert_eq!(
            message(&m),
            "slider \"s\" is pinned, through its links, to ground or a rigid body: over-constrained"
        );
        // two sliders on one point
        let mut m = two();
        m.sliders = vec![slider("s"), slider("t")];
        m.pins = vec![
            pin("P", node(0, 2), Endpoint::Slider(0)),
            pin("Q", node(1, 2), Endpoint::Slider(1)),
            pin("R", node(0, 2), node(1, 2)),
        ];
        assert_eq!(
            message(&m),
            "sliders \"s\" and \"t\" are pinned to the same point: over-constrained"
        );
        // a node on a slider with a one-direction support
        let mut m = two();
        m.sliders.push(slider("s"));
        m.pins = vec![pin("P", node(0, 1), Endpoint::Slider(0))];
        m.supports.push(Support {
            link: 0,
            node: 1,
            fixed: [false, true, false],
        });
        assert_eq!(
            message(&m),
            "node 1 of link \"a\" has a support and is on slider \"s\": over-constrained"
        );
        // a pinned node with a one-direction support
        let mut m = two();
        m.pins = vec![pin("P", node(0, 1), node(1, 2))];
        m.supports.push(Support {
            link: 0,
            node: 1,
            fixed: [true, false, false],
        });
        assert_eq!(
            message(&m),
            "node 1 of link \"a\" has a one-direction support and is pinned to another link: not supported \
             (over-constrained in general)"
        );
        // nothing left to solve for
        let m = Mechanism {
            links: vec![link("a", 1)],
            supports: vec![clamp(0, 0), clamp(0, 1)],
            ..Default::default()
        };
        assert_eq!(message(&m), "the mechanism has no free elastic degree of freedom");
    }

    /// A rigid link's node 1 takes node 0's unknowns with the link's length as lever: pinned at
    /// node 0 to a flexible link (a shared global pair), its node 1 has that pair and node 0's
    /// rotation. The Flores slider-crank with an ideal piston pin (rigid rod held at node 0 by the
    /// crank, node 1 pinned to the slider) has no unknown at all; with a clearance joint there,
    /// the rod's rotation and the slider's travel.
    #[test]
    fn a_rigid_links_node_1_follows_node_0() {
        let mut bar = link("bar", 1);
        bar.rigid = Some(crate::model::mechanism::RigidBody {
            mass: 1.0,
            inertia: 0.01,
            centroid: 0.05,
        });
        let mech = Mechanism {
            links: vec![link("arm", 2), bar],
            supports: vec![clamp(0, 0)],
            pins: vec![pin("P", node(0, 2), node(1, 0))],
            ..Default::default()
        };
        let map = number(&mech).unwrap();
        assert_eq!(map.nodes[1][0], global([3, 4], 6));
        assert_eq!(
            map.nodes[1][1],
            NodeMap {
                trans: Trans::Global([3, 4]),
                rot: 6,
                lever: 0.1
            }
        );
        assert_eq!(map.n, 7);
        let ideal = crate::scenes::FloresSliderCrank {
            clearance: None,
            ..Default::default()
        };
        let map = number(&ideal.build().unwrap()).unwrap();
        assert_eq!(map.n, 0);
        assert_eq!(map.slider_dof, vec![NONE]);
        assert_eq!(map.nodes[0][1].trans, Trans::Fixed);
        let map = number(&crate::scenes::FloresSliderCrank::default().build().unwrap()).unwrap();
        assert_eq!(map.n, 2);
        assert_eq!(
            map.nodes[0][1],
            NodeMap {
                trans: Trans::Fixed,
                rot: 0,
                lever: 0.12
            }
        );
        assert_eq!(map.slider_dof, vec![1]);
    }

    /// The plan keeps the numbering for the Newton and constant-rate kinds, not for the constant
    /// one.
    #[test]
    fn the_plan_keeps_the_numbering_of_the_moving_frame_steppers() {
        let mut spinning = link("arm", 4);
        spinning.frame = frame(Rotation::Constant {
            angle0: 0.0,
            rate: 10.0,
        });
        spinning.terms.geometric = Some(false);
        let mech = Mechanism {
            links: vec![spinning],
            supports: vec![clamp(0, 0)],
            ..Default::default()
        };
        let expected = number(&mech).unwrap();
        let mut settings = Settings::new(0.01, 1e-4);
        let plan = Plan::compile(&mech, &settings).unwrap();
        assert_eq!(plan.kind, StepperKind::ConstantRate);
        assert_eq!(plan.dofs(), Some(&expected));
        settings.stepper = Some(StepperKind::Newton);
        let plan = Plan::compile(&mech, &settings).unwrap();
        assert_eq!(plan.kind, StepperKind::Newton);
        assert_eq!(plan.dofs(), Some(&expected));
        // the constant stepper runs the translating model: no moving-frame numbering
        let still = Mechanism {
            links: vec![link("arm", 4)],
            joints: vec![Clearance {
                friction: None,
                name: "J".into(),
                journal: node(0, 0),
                bearing: ground(),
                clearance: 1e-4,
                law: bearing(),
            }],
            ..Default::default()
        };
        settings.stepper = None;
        let plan = Plan::compile(&still, &settings).unwrap();
        assert_eq!(plan.kind, StepperKind::Constant, "{}", plan.reason);
        assert_eq!(plan.dofs(), None);
    }
}
