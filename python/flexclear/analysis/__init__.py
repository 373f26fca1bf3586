"""Research tools built on the model: the speed/accuracy report (:mod:`.accuracy`), the comparison
of two studies' output distributions (:mod:`.distributions`), the stability
map of the clearance couplings (:mod:`.stability`) and the numpy matrices of one link that both
check against (:mod:`.linear`)."""
