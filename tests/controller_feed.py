"""A Controller fed the frames of an upright, standing robot, tick by tick (no rig, no physics)."""
import can

from wheelleg.controller import constants as C
from wheelleg.controller import params as P
from wheelleg.controller.node import Controller
from wheelleg.controller.state import CAN1, CAN2
from wheelleg.dbc import cybergear as cg
from wheelleg.dbc import load_bus, truncating_raw

DB1, DB2 = load_bus("can1"), load_bus("can2")
HEARTBEAT = DB1.get_message_by_name("Heartbeat")
_ESC_CMD = DB1.get_message_by_name("C620_Cmd_1_4")


def _std(name, **signals):
    msg = DB1.get_message_by_name(name)
    return can.Message(arbitration_id=msg.frame_id, data=msg.encode(signals, strict=False), is_extended_id=False)


def _joint_feedback(motor_id, faults=()):
    msg = DB2.get_message_by_name("CG_Feedback")
    raw = {s.name: truncating_raw(s, 0.0) for s in msg.signals}
    raw["Temp"] = 300
    return can.Message(arbitration_id=cg.reply_id(cg.T_FEEDBACK, motor_id, C.CG_HOST_ID, 2, faults),
                       data=msg.encode(raw, scaling=False), is_extended_id=True)


class Robot:
    """Feeds a Controller the frames of an upright robot, tick by tick, with devices switchable off."""

    def __init__(self):
        self.ctl = Controller()
        self.silent: set = set()
        self.faults: dict = {}
        self.reenable = 0
        self.imu_frozen = False  # the IMU repeats its frames bit for bit
        self.esc_held: dict = {}  # esc id -> A it reports whatever it is told (a hung C620)
        self.tick_no = 0
        self.sent: list = []

    def frames(self):
        out = [(CAN2, _joint_feedback(j.motor_id, self.faults.get(j.name, ())))
               for j in C.JOINTS if j.name not in self.silent]
        out += [(CAN1, _std(f"C620_Feedback_{w.esc_id}", RotorAngle=0, RotorSpeed=0,
                            TorqueCurrent=self.esc_held.get(w.esc_id, self._commanded_a(w.esc_id)),
                            MotorTemp=30)) for w in C.WHEELS if w.name not in self.silent]
        if "imu" not in self.silent:
            out += [(CAN1, _std("IMU_Orientation", QuatW=1.0, QuatX=0.0, QuatY=0.0, QuatZ=0.0)),
                    # a real IMU's noise changes its frames every sample (a frozen one is offline)
                    (CAN1, _std("IMU_Gyro", RateX=0.001 * (self.tick_no % 2 and not self.imu_frozen),
                                RateY=0.0, RateZ=0.0)),
                    (CAN1, _std("IMU_Accel", AccX=0.0, AccY=0.0, AccZ=9.81))]
        if "remote" not in self.silent:
            out.append((CAN1, _std("Operator", Mode=1, Jump=0, JumpForward=0, Reenable=self.reenable,
                                   SpeedX=0.0, YawRate=0.0, LegLength=0.17, Pitch=0.0, Roll=0.0)))
        return out

    def _commanded_a(self, esc_id: int) -> float:
        """A healthy C620 reports the current it was last told (0x200 slot ``esc_id``)."""
        if not self.sent:
            return 0.0
        frame = [m for m in self.sent[-1].frames[CAN1] if m.arbitration_id == _ESC_CMD.frame_id][0]
        return _ESC_CMD.decode(bytes(frame.data))[f"ESC{esc_id}_Current"]

    def step(self, n: int = 1):
        for _ in range(n):
            now = self.tick_no * P.CONTROL_PERIOD
            for bus, msg in self.frames():
                self.ctl.on_frame(msg, bus, now)
            result = self.ctl.tick(self.tick_no, now)
            self.sent.append(result)
            self.tick_no += 1
        return self.sent[-1]

    def heartbeat(self) -> dict:
        return HEARTBEAT.decode(bytes(self.sent[-1].frames[CAN1][-1].data))
