"""``labsim grade``: a class's submissions checked against an assignment, run, scored and reported."""
