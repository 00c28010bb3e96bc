// Synthetic worlds with known truth, shared by the tests (Cartographer's
// GenerateFake... helpers in spirit).
#ifndef SWEEPSCAN_TESTS_TESTING_WORLDS_H_
#define SWEEPSCAN_TESTS_TESTING_WORLDS_H_

#include "core/cloud/reconstruct.h"
#include "core/sim/world.h"

namespace sweepscan::testing {

// The paper's lab with a drive that sees every wall: along the room, a
// half turn in place at the far end, and back.
sim::SimConfig LabConfig(uint64_t seed = 1);
// The paper's calibration drive: a circle of radius 0.83 m at 0.2 m/s around
// a centre 1.7 m in front of the target board, slightly more than one turn.
sim::SimConfig CircleConfig(uint64_t seed = 1);
// The office floor's drives (resources/scenarios/building_{a,b,c}.json, the
// same paths): 'a' from room A through the corridor into room B, 'b' from
// room B into room C, 'c' along the corridor. config.start is where the
// operator put the robot down: the truth a project's registration is
// checked against (a session's own frame is its start pose).
sim::SimConfig BuildingConfig(char drive, uint64_t seed = 1);
// A drive with a pause in the middle, for holes cut into its records (a link
// outage): straight, then an arc (0.3 m/s, 0.3 rad/s) from 8 s to 10 s,
// standing still from 10 s to 20 s, then on again.
sim::SimConfig GapDriveConfig(uint64_t seed = 1);
// Every sensor perfect (no noise, no dropouts, no scale error, no bias).
void MakeNoiseFree(sim::SimConfig* config);

// Simulates and reconstructs; truth poses are used when source == kTruth.
// ekf_gyro_bias: EkfOptions::estimate_gyro_bias (the default filter has it;
// references made with the filter before the bias state pass false).
ReconstructionResult SimulateAndReconstruct(const sim::SimConfig& config, PoseSource source,
                                            bool deskew, const MountingError& calibration = {},
                                            bool ekf_gyro_bias = EkfOptions().estimate_gyro_bias);

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_TESTING_WORLDS_H_
