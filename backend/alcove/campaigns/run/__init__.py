"""What runs in a worker: the job protocol every step job runs, the steps (which domain
computes each, with what), the candidate rows a batch's slots write, the reconciler."""
