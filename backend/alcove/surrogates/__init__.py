"""Model versions: trained surrogates with lineage, stored as JSON artifacts in blobs."""
