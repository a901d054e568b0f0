//! Gaussian-mixture reradiation models (Hua et al. 2022) as a whole: evaluating the colour
//! accuracy of fits of measured matrices (`evaluate`, with the colours compared in `colour`, the
//! matrices and illuminants read in `inputs` and the statistics in `summary`) and its box plots
//! (`boxplot`), and how much a fit depends on its seed and which number of Gaussians BIC
//! chooses (`robust`).

pub mod boxplot;
pub mod canvas;
pub mod colour;
pub mod evaluate;
pub mod figures;
pub mod fit;
pub mod inputs;
pub mod options;
pub mod robust;
pub mod summary;
