#include "legs.h"

#include <math.h>

#include "robot.h"
#include "wl_config.h"
#include "wl_math.h"


wl_attitude_t wl_attitude(const wl_imu_t *imu, const float bias[3]) {
    float w = imu->quat[0], x = imu->quat[1], y = imu->quat[2], z = imu->quat[3];
    wl_attitude_t a;
    a.roll = atan2f(2 * (w * x + y * z), 1 - 2 * (x * x + y * y));
    a.pitch = asinf(wl_clamp(2 * (w * y - z * x), 1.0f));
    a.yaw = atan2f(2 * (w * z + x * y), 1 - 2 * (y * y + z * z));
    a.wx = imu->gyro[0] - bias[0];
    a.wy = imu->gyro[1] - bias[1];
    a.wz = imu->gyro[2] - bias[2];
    return a;
}

bool wl_leg_state(const wl_bus_state_t *bus, int leg, const wl_attitude_t *att, wl_leg_state_t *out) {
    int front = wl_joint_of(leg, 0), rear = wl_joint_of(leg, 1);
    const wl_joint_fb_t *fa = &bus->joints[front], *fe = &bus->joints[rear];
    float sa = (float)WL_JOINTS[front].sign, se = (float)WL_JOINTS[rear].sign;
    float phi1 = WL_JOINTS[front].stop + sa * fa->position, phi4 = WL_JOINTS[rear].stop + se * fe->position;
    float dphi1 = sa * fa->speed, dphi4 = se * fe->speed;
    wl_leg_kin_t kin;
    if (!wl_fivebar_forward(phi1, phi4, &kin)) return false;
    float dL0, dphi0;
    wl_fivebar_velocity(&kin, dphi1, dphi4, &dL0, &dphi0);
    float body_rate = -att->wy;
    /* the wheel's stator sits on link BC: add the link's own rotation (numerically, as the Python) */
    const float eps = 1e-4f;
    float phi2_ahead;
    if (!wl_fivebar_shin_angle(phi1 + eps * dphi1, phi4 + eps * dphi4, &phi2_ahead)) phi2_ahead = kin.phi2;
    float dphi2 = wl_wrap(phi2_ahead - kin.phi2) / eps;
    int w = wl_wheel_of(leg);
    float spin = (float)WL_WHEELS[w].forward_sign * bus->wheels[w].speed + att->wy - dphi2;
    out->kin = kin;
    out->L0 = kin.L0;
    out->dL0 = dL0;
    out->theta = WL_PI / 2 - kin.phi0 + att->pitch;
    out->dtheta = -dphi0 - body_rate;
    out->wheel_speed = spin * WL_C_WHEEL_RADIUS;
    out->dphi1 = dphi1;
    out->dphi4 = dphi4;
    return true;
}

float wl_mean_speed(const wl_leg_state_t legs[2]) {
    return 0.5f * (legs[0].wheel_speed + legs[1].wheel_speed);
}

float wl_legs_under_body(const wl_leg_state_t legs[2]) {
    float sum = 0.0f;
    for (int i = 0; i < 2; i++) {
        sum += legs[i].dL0 * sinf(legs[i].theta) + legs[i].L0 * cosf(legs[i].theta) * legs[i].dtheta;
    }
    return -0.5f * sum;
}

float wl_turn_lean(float speed, float yaw_rate) {
    return -wl_clamp(atanf(speed * yaw_rate / WL_C_GRAVITY), WL_P_TURN_LEAN_LIMIT);
}

float wl_roll_leg_difference(float roll_set_point, float level_offset) {
    float feed_forward = 2.0f * WL_C_HALF_TRACK * tanf(roll_set_point);
    return wl_clamp(feed_forward + level_offset, WL_P_ROLL_LEVEL_LIMIT);
}

void wl_leg_targets(float length, float difference, float targets[2]) {
    length = wl_within(length, WL_P_LEG_LENGTH_MIN, WL_P_LEG_LENGTH_MAX);
    float half = 0.5f * wl_minf(fabsf(difference), WL_P_LEG_LENGTH_MAX - WL_P_LEG_LENGTH_MIN);
    float mean = wl_within(length, WL_P_LEG_LENGTH_MIN + half, WL_P_LEG_LENGTH_MAX - half);
    float sign = difference >= 0.0f ? 1.0f : -1.0f;
    targets[WL_LEFT] = mean + sign * half;
    targets[WL_RIGHT] = mean - sign * half;
}

float wl_ease_jerk(float target) {
    float over = fabsf(target) - WL_P_SPEED_EASE_TOP_FROM;
    if (over <= 0.0f) {
        return WL_P_SPEED_EASE_JERK;
    }
    float slope = (WL_P_SPEED_EASE_JERK_TOP - WL_P_SPEED_EASE_JERK) / (WL_P_SPEED_LIMIT - WL_P_SPEED_EASE_TOP_FROM);
    return WL_P_SPEED_EASE_JERK + slope * wl_minf(over, WL_P_SPEED_LIMIT - WL_P_SPEED_EASE_TOP_FROM);
}

void wl_speed_set_point(float *speed, float *accel, float target, float dt) {
    float gap = target - *speed;
    float direction = gap > 0.0f ? 1.0f : gap < 0.0f ? -1.0f : 0.0f;
    float landing = sqrtf(2.0f * wl_ease_jerk(target) * fabsf(gap));
    float a = *accel;
    if (a * direction >= landing) {
        a = direction * landing;
    } else {
        float aim = direction * wl_minf(WL_P_ACCEL_LIMIT, landing);
        a += wl_maxf(-WL_P_SPEED_JERK * dt, wl_minf(WL_P_SPEED_JERK * dt, aim - a));
    }
    float v = *speed + a * dt;
    if ((target - v) * direction <= 0.0f) {
        *speed = target;
        *accel = 0.0f;
        return;
    }
    *speed = v;
    *accel = a;
}

wl_travel_t wl_travel_phase(float speed, float accel) {
    if (accel * speed < 0.0f) return WL_TRAVEL_BRAKING;
    if (accel != 0.0f) return WL_TRAVEL_SPEEDING_UP;
    return speed != 0.0f ? WL_TRAVEL_CRUISING : WL_TRAVEL_STANDING;
}
