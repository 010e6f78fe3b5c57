//! penumbra-transport: Modular Radiance Transfer operators. Work in progress (issue 6).
