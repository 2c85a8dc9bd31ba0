//! The recipes: one function per figure or study, each computing its data
//! with the solvers, writing its charts and CSV files, and returning its
//! section of the report.

pub mod accuracy;
pub mod common;
pub mod diffusion_limits;
pub mod dipole;
pub mod paint;
pub mod paper;
pub mod pareto;
pub mod rough_lobes;
pub mod savings;
pub mod speed;
pub mod stability;

use crate::context::Recipe;

/// Every recipe, in report order.
pub fn all() -> Vec<Recipe> {
    vec![
        ("fig3", paper::fig3),
        ("fig4", paper::fig4),
        ("fig5", speed::fig5),
        ("fig6", paper::fig6),
        ("fig7", paper::fig7),
        ("fig9", paper::fig9),
        ("fig10", paper::fig10),
        ("speedup", speed::speedup),
        ("dipole", dipole::recipe),
        ("diffusion-limits", diffusion_limits::recipe),
        ("pareto", pareto::recipe),
        ("stability", stability::recipe),
        ("savings", savings::recipe),
        ("paint", paint::recipe),
        ("rough-lobes", rough_lobes::recipe),
    ]
}
