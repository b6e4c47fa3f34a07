"""The model: systems and their front doors, array namespaces, checks, parameters, fingerprints."""
