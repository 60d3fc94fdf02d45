//! The typed layout of a parameter vector: named blocks of declared
//! parameters. Code outside this type asks for values by name or for a
//! block's values; it never slices `theta` by position.
//!
//! ```
//! use hbis::model::{Layout, ParamSpec};
//!
//! let layout = Layout::new(vec![
//!     ("release".into(), vec![ParamSpec::new("u0", "m", (0.0, 1.0), 0.1)]),
//!     ("offset".into(), vec![ParamSpec::new("a_off", "m/s^2", (-1.0, 1.0), 0.0)]),
//! ]);
//! let theta = [0.08, 0.01];
//! assert_eq!(layout.get(&theta, "a_off"), Some(0.01));
//! assert_eq!(layout.values(&theta, 1), &[0.01]);
//! assert_eq!(layout.names(), ["u0", "a_off"]);
//! ```

use std::ops::Range;

/// One parameter of a component: what it is, in which unit, where its
/// prior lives and which value switches the component off.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamSpec {
    /// Name in `theta`, outputs and prior files (e.g. `r_mu`).
    pub name: String,
    /// Mathematical symbol (e.g. `mu_slow/mu_fast`).
    pub symbol: String,
    /// SI unit (`-` for a ratio).
    pub unit: String,
    /// Default prior: uniform on these bounds.
    pub bounds: (f64, f64),
    /// The value at which the component has no effect (its warm start when
    /// the component is added to a fitted model).
    pub neutral: f64,
    /// One line: the physical meaning.
    pub meaning: String,
    /// A physically meaningful change of the parameter, in its unit: the
    /// yardstick reports use to judge a posterior sd.
    pub scale: f64,
    /// How a record shows the parameter (which feature of the acceleration
    /// it changes): the identifiability report's physical explanation.
    /// Empty when not declared.
    pub shows: String,
}

impl ParamSpec {
    /// A parameter with its name, unit, bounds and neutral value; the
    /// symbol defaults to the name and the scale to a tenth of the bounds.
    pub fn new(name: &str, unit: &str, bounds: (f64, f64), neutral: f64) -> Self {
        Self {
            name: name.to_string(),
            symbol: name.to_string(),
            unit: unit.to_string(),
            bounds,
            neutral,
            meaning: String::new(),
            scale: 0.1 * (bounds.1 - bounds.0),
            shows: String::new(),
        }
    }

    /// With a symbol.
    pub fn symbol(mut self, s: &str) -> Self {
        self.symbol = s.to_string();
        self
    }

    /// With a meaning.
    pub fn meaning(mut self, s: &str) -> Self {
        self.meaning = s.to_string();
        self
    }

    /// With a physical scale.
    pub fn scale(mut self, s: f64) -> Self {
        self.scale = s;
        self
    }

    /// With how a record shows it.
    pub fn shows(mut self, s: &str) -> Self {
        self.shows = s.to_string();
        self
    }
}

/// One named block of parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    /// The component (or part of the model) that owns the block.
    pub name: String,
    /// Its parameters, in order.
    pub params: Vec<ParamSpec>,
    range: Range<usize>,
}

impl Block {
    /// Where the block sits in `theta`.
    pub fn range(&self) -> Range<usize> {
        self.range.clone()
    }
}

/// Named blocks laid end to end.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Layout {
    blocks: Vec<Block>,
    len: usize,
}

impl Layout {
    /// Blocks in order.
    pub fn new(blocks: Vec<(String, Vec<ParamSpec>)>) -> Self {
        let mut out = Self::default();
        for (name, params) in blocks {
            out.push(name, params);
        }
        out
    }

    /// The layout with one more block at the end.
    pub fn push(&mut self, name: String, params: Vec<ParamSpec>) {
        let range = self.len..self.len + params.len();
        self.len = range.end;
        self.blocks.push(Block {
            name,
            params,
            range,
        });
    }

    /// Number of parameters.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether it has no parameter.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The blocks.
    pub fn blocks(&self) -> &[Block] {
        &self.blocks
    }

    /// Every parameter, in order.
    pub fn params(&self) -> impl Iterator<Item = &ParamSpec> {
        self.blocks.iter().flat_map(|b| b.params.iter())
    }

    /// Every parameter name, in order.
    pub fn names(&self) -> Vec<String> {
        self.params().map(|p| p.name.clone()).collect()
    }

    /// Default bounds of every parameter.
    pub fn bounds(&self) -> Vec<(f64, f64)> {
        self.params().map(|p| p.bounds).collect()
    }

    /// Position of a parameter.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.params().position(|p| p.name == name)
    }

    /// The declaration of a parameter.
    pub fn spec(&self, name: &str) -> Option<&ParamSpec> {
        self.params().find(|p| p.name == name)
    }

    /// The block that owns a parameter.
    pub fn owner(&self, name: &str) -> Option<&Block> {
        self.blocks
            .iter()
            .find(|b| b.params.iter().any(|p| p.name == name))
    }

    /// The value of a parameter.
    pub fn get(&self, theta: &[f64], name: &str) -> Option<f64> {
        self.index(name).and_then(|i| theta.get(i).copied())
    }

    /// The values of block `i`.
    pub fn values<'a>(&self, theta: &'a [f64], i: usize) -> &'a [f64] {
        &theta[self.blocks[i].range.clone()]
    }

    /// The values of the first `blocks` blocks (a model's own parameters
    /// before any appended noise block).
    pub fn head<'a>(&self, theta: &'a [f64], blocks: usize) -> &'a [f64] {
        let end = self.blocks[..blocks].last().map_or(0, |b| b.range.end);
        &theta[..end]
    }

    /// A vector for this layout, each value given by `value` (by name).
    pub fn theta_from(&self, value: &dyn Fn(&ParamSpec) -> f64) -> Vec<f64> {
        self.params().map(value).collect()
    }
}
