"""granflow post-processing: dump readers, kernels and fields, scene analyses, fits, plots."""
