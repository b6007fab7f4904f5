"""Studies over many cars: global sensitivity (Sobol, Morris), the fast band path that
makes them affordable, and fleet risk. Stand on the dynamics and the wear."""
