//! Gaussian-mixture reradiation models (Hua et al. 2022) as a whole: evaluating the colour
//! accuracy of fits of measured matrices (`evaluate`) and its box plots (`boxplot`).

pub mod boxplot;
pub mod evaluate;
pub mod fit;
