"""The discrepancy detective (CONTRACT section 7): locate where a physical network disagrees
with measured data beyond the noise, name the physics it lacks, add it and show the fit
improve. See :func:`vfmodel.detective.diagnose.diagnose`."""
