//! Any bytes as an attached NRRD file (`.nrrd`): never a panic, never an unbounded allocation, and every
//! volume it accepts is consistent (voxel count = product of sizes, finite values inside the value range).
#![no_main]

use libfuzzer_sys::fuzz_target;
use metamer_core::volume::nrrd;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Ok(v) = nrrd::from_bytes(Path::new("/nonexistent/fuzz.nrrd"), data) {
        let values = v.voxels.to_f32_vec();
        assert_eq!(values.len(), v.dims.iter().product::<usize>());
        assert!(values.iter().all(|x| x.is_finite() && *x >= v.value_range[0] && *x <= v.value_range[1]));
        assert!(v.spacing.iter().all(|s| s.is_finite() && *s > 0.0));
    }
});
