//! penumbra-fiv: Fullsphere Irradiance Vector occlusion bake (FIV §4.2). Work in progress (issue 5).
