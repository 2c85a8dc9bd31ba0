//! The recipes: one function per figure or study, each computing its data
//! with the solvers, writing its charts and CSV files, and returning its
//! section of the report.

pub mod stability;

use crate::reproduce::Recipe;

/// Every recipe, in report order.
pub fn all() -> Vec<Recipe> {
    vec![("stability", stability::recipe)]
}
