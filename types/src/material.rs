//! Material models and material edits.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// A name that is not one of an enum's spellings.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown {what} {name:?} (expected one of: {expected})")]
pub struct UnknownName {
    /// What was being named ("material model", "object kind").
    pub what: &'static str,
    /// The name given.
    pub name: String,
    /// The accepted names, comma-separated.
    pub expected: String,
}

/// A constitutive model (docs/reference/scene-format.md, "`material`"; one file each in
/// `sim-core/src/material/`).
///
/// Scene files and commands name it in kebab-case (`jelly`, `neo-hookean`, `snow`, `sand`,
/// `metal`, `plasticine`, `foam`); `fixed-corotated` and `corotated` are accepted for `jelly`.
/// The discriminant is the wire code (`CommandMsg::code`).
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MaterialModel {
    /// Fixed-corotated elasticity (Stomakhin et al. 2012), "jelly".
    #[default]
    #[serde(rename = "jelly", alias = "fixed-corotated", alias = "corotated")]
    FixedCorotated = 0,
    /// Compressible neo-Hookean elasticity.
    #[serde(alias = "neohookean")]
    NeoHookean = 1,
    /// Snow: fixed-corotated with plastic hardening (Stomakhin et al. 2013).
    Snow = 2,
    /// Sand: Drucker-Prager plasticity on Hencky strain (Klár et al. 2016).
    Sand = 3,
    /// Metal: von Mises plasticity on Hencky strain.
    Metal = 4,
    /// Plasticine: von Mises with softening.
    Plasticine = 5,
    /// Foam: von Mises on Hencky strain with volume change.
    Foam = 6,
}

impl MaterialModel {
    /// Every model, in wire-code order.
    pub const ALL: [Self; 7] = [
        Self::FixedCorotated,
        Self::NeoHookean,
        Self::Snow,
        Self::Sand,
        Self::Metal,
        Self::Plasticine,
        Self::Foam,
    ];

    /// The scene-file name (`jelly`, `neo-hookean`, ...).
    pub const fn name(self) -> &'static str {
        match self {
            Self::FixedCorotated => "jelly",
            Self::NeoHookean => "neo-hookean",
            Self::Snow => "snow",
            Self::Sand => "sand",
            Self::Metal => "metal",
            Self::Plasticine => "plasticine",
            Self::Foam => "foam",
        }
    }

    /// The wire code.
    pub const fn code(self) -> u32 {
        self as u32
    }

    /// Decodes a wire code (`None` for an unknown one).
    pub fn from_code(code: u32) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.code() == code)
    }

    /// The accepted names, comma-separated (for error messages and `--help`).
    pub fn names() -> String {
        Self::ALL.map(Self::name).join(", ")
    }
}

impl fmt::Display for MaterialModel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for MaterialModel {
    type Err = UnknownName;

    /// Parses a name case-insensitively, `_` read as `-`; the serde aliases are accepted.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let key = s.trim().to_ascii_lowercase().replace('_', "-");
        Ok(match key.as_str() {
            "fixed-corotated" | "corotated" => Self::FixedCorotated,
            "neohookean" => Self::NeoHookean,
            _ => Self::ALL
                .into_iter()
                .find(|m| m.name() == key)
                .ok_or_else(|| UnknownName {
                    what: "material model",
                    name: s.to_string(),
                    expected: Self::names(),
                })?,
        })
    }
}

/// A change of an object's material: `None` keeps the current value, so an edit changes only
/// the fields it names (a snow object keeps its θc, θs and ξ when only E is edited).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialEdit {
    /// New constitutive model.
    #[serde(default)]
    pub model: Option<MaterialModel>,
    /// Young's modulus E, Pa (> 0).
    #[serde(default)]
    pub youngs_modulus_pa: Option<f64>,
    /// Poisson's ratio nu, in (-1, 0.5).
    #[serde(default)]
    pub poisson_ratio: Option<f64>,
    /// Density, kg/m³ (> 0).
    #[serde(default)]
    pub density_kg_m3: Option<f64>,
    /// Coefficient of restitution e, in [0, 1].
    #[serde(default)]
    pub restitution: Option<f64>,
    /// Coulomb friction coefficient mu (>= 0).
    #[serde(default)]
    pub friction: Option<f64>,
}

impl MaterialEdit {
    /// Whether the edit changes the constitutive model or its elastic parameters (as opposed to
    /// only the contact coefficients e and mu).
    pub fn changes_material(&self) -> bool {
        self.model.is_some()
            || self.youngs_modulus_pa.is_some()
            || self.poisson_ratio.is_some()
            || self.density_kg_m3.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_model_round_trips_through_name_code_and_serde() {
        for m in MaterialModel::ALL {
            assert_eq!(m.name().parse::<MaterialModel>(), Ok(m));
            assert_eq!(MaterialModel::from_code(m.code()), Some(m));
            #[derive(Serialize, Deserialize)]
            struct Doc {
                model: MaterialModel,
            }
            let text = toml::to_string(&Doc { model: m }).unwrap();
            assert_eq!(text.trim(), format!("model = \"{}\"", m.name()));
            assert_eq!(toml::from_str::<Doc>(&text).unwrap().model, m);
        }
        assert_eq!(MaterialModel::from_code(7), None);
    }

    #[test]
    fn aliases_parse_and_unknown_names_list_the_choices() {
        assert_eq!("Fixed_Corotated".parse(), Ok(MaterialModel::FixedCorotated));
        assert_eq!("neohookean".parse(), Ok(MaterialModel::NeoHookean));
        let e = "rubber".parse::<MaterialModel>().unwrap_err();
        assert!(e.to_string().contains("jelly, neo-hookean, snow"), "{e}");
    }
}
