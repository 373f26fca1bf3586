//! What every straight flexible link is made of, whatever moves it: the beam data and element
//! count of [`mechanism::Link`] (the one user model, [`Mechanism`]) and of [`FlexibleLink`] (its
//! translating form the constant stepper runs), and the one validation of that data, of initial
//! elastic states and of node references that both use.
//!
//! [`FlexibleLink`]: crate::plan::translating::FlexibleLink
//! [`mechanism::Link`]: super::mechanism::Link
//! [`Mechanism`]: super::mechanism::Mechanism

use std::fmt::Display;

use crate::element::BeamElement;
use crate::error::{check_non_negative, check_positive, Error, Result};

use super::NODE_DOFS;

/// The largest element count of one link (3 000 003 DOFs): more is refused as an invalid
/// parameter rather than attempted (the assembly would exhaust memory).
pub const MAX_ELEMENTS: usize = 1_000_000;

/// The allowed element counts in words, as error messages give them.
pub const ELEMENTS_ALLOWED: &str = "an integer in 1 ..= 1000000";

/// Checks an element count given as any integer type (a `usize` field, an `i64` from Python):
/// `1 ..= MAX_ELEMENTS`. Returns it as `usize`; fails with [`Error::InvalidParameter`] naming
/// `name`.
pub fn check_elements<T>(name: &str, elements: T) -> Result<usize>
where
    T: TryInto<usize> + Display + Copy,
{
    elements
        .try_into()
        .ok()
        .filter(|n| (1..=MAX_ELEMENTS).contains(n))
        .ok_or_else(|| Error::param(name, elements, ELEMENTS_ALLOWED))
}

/// A straight link of `elements` equal beam elements: its length and section (SI units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamSection {
    /// Length L, m.
    pub length: f64,
    /// Number of elements N, `1 ..= MAX_ELEMENTS`.
    pub elements: usize,
    /// Young's modulus E, Pa.
    pub youngs_modulus: f64,
    /// Density rho, kg/m^3.
    pub density: f64,
    /// Kelvin-Voigt damping eta, Pa s.
    pub damping: f64,
    /// Section area A, m^2.
    pub area: f64,
    /// Second moment of area I, m^4.
    pub inertia: f64,
}

impl BeamSection {
    /// Element length l = L / N, m.
    pub fn element_length(&self) -> f64 {
        self.length / self.elements as f64
    }

    /// Number of DOFs, `3 (N + 1)`.
    pub fn dofs(&self) -> usize {
        NODE_DOFS * (self.elements + 1)
    }

    /// The element all of whose copies make up the link.
    pub fn element(&self, rotary_inertia: bool) -> BeamElement {
        BeamElement {
            length: self.element_length(),
            youngs_modulus: self.youngs_modulus,
            density: self.density,
            area: self.area,
            inertia: self.inertia,
            damping: self.damping,
            rotary_inertia,
        }
    }

    /// Checks, in this order: length, elements (`1 ..= MAX_ELEMENTS`), E, rho, eta (>= 0), A, I:
    /// each finite and > 0 but eta. Parameters are named `{prefix}length`, ... (for example
    /// `links[0].length`).
    pub fn validate(&self, prefix: &str) -> Result<()> {
        let p = |f: &str| format!("{prefix}{f}");
        check_positive(&p("length"), self.length, "m")?;
        check_elements(&p("elements"), self.elements)?;
        check_positive(&p("youngs_modulus"), self.youngs_modulus, "Pa")?;
        check_positive(&p("density"), self.density, "kg/m^3")?;
        check_non_negative(&p("damping"), self.damping, "Pa s")?;
        check_positive(&p("area"), self.area, "m^2")?;
        check_positive(&p("inertia"), self.inertia, "m^4")?;
        // the element matrices must be finite: an element length that underflows (a link of
        // 5e-324 m) made EI / Le^3 infinite, and LAPACK hung on the matrices (fuzz 42:88194)
        let le = self.element_length();
        let bending = self.youngs_modulus * self.inertia / (le * le * le);
        let axial = self.youngs_modulus * self.area / le;
        if !(le.is_normal() && bending.is_finite() && axial.is_finite()) {
            return Err(Error::param(
                p("length"),
                self.length,
                format!(
                    "an element length length / elements = {le:e} m whose element stiffness is finite (EI / Le^3 = {bending:e} N/m, EA / Le = {axial:e} N/m)"
                ),
            ));
        }
        Ok(())
    }

    /// Checks the optional initial elastic displacement and velocity: `3 (N + 1)` finite values
    /// each, named `{prefix}initial_displacement` and `{prefix}initial_velocity`.
    pub fn validate_initial_state(
        &self,
        prefix: &str,
        initial_displacement: Option<&[f64]>,
        initial_velocity: Option<&[f64]>,
    ) -> Result<()> {
        for (label, v) in [
            ("initial_displacement", initial_displacement),
            ("initial_velocity", initial_velocity),
        ] {
            let Some(v) = v else { continue };
            let name = format!("{prefix}{label}");
            if v.len() != self.dofs() {
                return Err(Error::param(
                    name,
                    format!("{} values", v.len()),
                    format!("{} values (3 per node)", self.dofs()),
                ));
            }
            if let Some(k) = v.iter().position(|x| !x.is_finite()) {
                return Err(Error::param(format!("{name}[{k}]"), v[k], "finite values"));
            }
        }
        Ok(())
    }
}

/// Checks that link #`link` exists and has node `node`. `links` gives each link's name and element
/// count; `owner` names the container in the message ("model", "mechanism"). A missing link is
/// [`Error::InvalidModel`]; a missing node [`Error::InvalidParameter`] named `name` with the
/// allowed range `0 ..= N`.
pub fn check_node<'a>(
    name: &str,
    owner: &str,
    mut links: impl ExactSizeIterator<Item = (&'a str, usize)>,
    link: usize,
    node: usize,
) -> Result<()> {
    let count = links.len();
    let Some((link_name, elements)) = links.nth(link) else {
        return Err(Error::InvalidModel {
            message: format!("{name}: link #{link} does not exist (the {owner} has {count})"),
        });
    };
    if node > elements {
        return Err(Error::param(
            name,
            node,
            format!("a node of link {link_name:?}: 0 ..= {elements}"),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn element_counts_outside_one_to_a_million_are_refused_by_name() {
        assert_eq!(check_elements("n", 1usize), Ok(1));
        assert_eq!(check_elements("n", MAX_ELEMENTS as i64), Ok(MAX_ELEMENTS));
        for (bad, shown) in [(0i64, "0"), (-3, "-3"), (MAX_ELEMENTS as i64 + 1, "1000001")] {
            let e = check_elements("links[2].elements", bad).unwrap_err();
            assert_eq!(e, Error::param("links[2].elements", shown, ELEMENTS_ALLOWED));
        }
    }

    #[test]
    fn node_references_name_the_link_and_the_node_range() {
        let links = [("a", 2usize), ("b", 4)];
        let it = || links.iter().map(|&(n, e)| (n, e));
        assert!(check_node("x", "model", it(), 1, 4).is_ok());
        let e = check_node("pins[0].a", "mechanism", it(), 1, 5).unwrap_err();
        assert_eq!(
            e.to_string(),
            "invalid parameter `pins[0].a` = 5: allowed a node of link \"b\": 0 ..= 4"
        );
        let e = check_node("joints[0].node", "model", it(), 2, 0).unwrap_err();
        assert_eq!(
            e.to_string(),
            "invalid model: joints[0].node: link #2 does not exist (the model has 2)"
        );
    }

    #[test]
    fn section_checks_run_in_order_and_name_the_prefixed_parameter() {
        let ok = BeamSection {
            length: 1.0,
            elements: 4,
            youngs_modulus: 2e11,
            density: 7850.0,
            damping: 0.0,
            area: 1e-4,
            inertia: 1e-9,
        };
        assert!(ok.validate("links[0].").is_ok());
        let name = |s: BeamSection| match s.validate("links[1].") {
            Err(Error::InvalidParameter { name, .. }) => name,
            r => panic!("{r:?}"),
        };
        // Two faults: the first in the documented order is reported.
        assert_eq!(
            name(BeamSection {
                length: -1.0,
                elements: 0,
                ..ok
            }),
            "links[1].length"
        );
        assert_eq!(
            name(BeamSection {
                elements: 0,
                area: 0.0,
                ..ok
            }),
            "links[1].elements"
        );
        assert_eq!(name(BeamSection { damping: -1.0, ..ok }), "links[1].damping");
        assert_eq!(
            name(BeamSection {
                inertia: f64::NAN,
                ..ok
            }),
            "links[1].inertia"
        );
        assert!(ok.validate_initial_state("p.", Some(&[0.0; 15]), None).is_ok());
        let e = ok.validate_initial_state("p.", None, Some(&[0.0; 14])).unwrap_err();
        assert_eq!(
            e,
            Error::param("p.initial_velocity", "14 values", "15 values (3 per node)")
        );
        let mut v = [0.0; 15];
        v[7] = f64::INFINITY;
        let e = ok.validate_initial_state("p.", Some(&v), None).unwrap_err();
        assert_eq!(
            e,
            Error::param("p.initial_displacement[7]", f64::INFINITY, "finite values")
        );
    }
}
