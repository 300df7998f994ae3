"""The flat layout of a guarded teleop command (one float64 array of ``COMMAND_SIZE``: ring_b's
position in ring_a [m], its (x, y, z, w) quaternion, the leg lengths [m], the PoseMargins and the
inverse condition number) and the outcome codes of a guarded step, as constants numba compiles."""

QUATERNION = 3
LENGTHS = 7
STROKE = 13
UNIVERSAL = 19
SPHERICAL = 25
INTERFERENCE = 31
INVERSE_CONDITION = 46
COMMAND_SIZE = 47

#: Outcome of one guarded step.
STEP_UNCHANGED = 0      # the target is the last command: nothing to do
STEP_ACCEPTED = 1       # the buffer holds the new command
STEP_REFUSED = 2        # the step would break (or worsen a broken) margin: hold
STEP_FK_FAILED = 3      # joint mode: the FK of the candidate lengths did not converge: hold

#: A step within this relative margin of a speed limit is within the limit. The compiled and the
#: NumPy guards compute a step to about 1e-15; a master that moves at exactly the slave's limit
#: (as the tests' master model can) must not be speed-limited by one and not by the other.
SPEED_TOLERANCE = 1e-9

#: What limited the step (mapped onto TeleopCode by the mapping).
LIMIT_NONE = 0
LIMIT_SPEED = 1
LIMIT_SINGULARITY_DECELERATE = 2
LIMIT_SINGULARITY_HALT = 3
LIMIT_COLLISION_DECELERATE = 4
LIMIT_COLLISION_HALT = 5

#: The margin a refused step breaks, in the order they are checked.
CHECK_STROKE = 0
CHECK_UNIVERSAL = 1
CHECK_SPHERICAL = 2
CHECK_INTERFERENCE = 3
CHECK_CONDITIONING = 4
