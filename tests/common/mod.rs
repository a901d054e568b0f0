pub mod ray_sets;
