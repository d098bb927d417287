"""Frame types of the swarm middleware and their payload sizes (bytes, chosen encodings).

Join protocol (seed 000 §3.4, Fig. 8), IR token ring (§3.3, Fig. 7), heading exchange and the
master's periodic broadcast (§3.5, Fig. 9), disperse (Fig. 4); seed 003's RUTA in the join protocol
(middleware/assignment.py): the joining answer with the candidate's status report
(``ruta_centralized``), the slot announcement and the bids (``ruta_decentralized``).
"""

SCAN = "scan"  # master -> waiting robots (broadcast; a rescan lists the robots already heard)
SCAN_RESPONSE = "scan_response"  # waiting robot -> master
JOIN_QUERY = "join_query"  # master -> joining candidates (broadcast, lists the candidates)
JOIN_ANSWER = "join_answer"  # candidate -> master: joining-available / joining-unavailable
STATUS_QUERY = "status_query"  # master -> joining candidates: the joining query asking for status (ruta_centralized)
STATUS_ANSWER = "status_answer"  # candidate -> master: the joining answer with its status report (ruta_centralized)
JOIN_NOTIFY = "join_notify"  # master -> robot: new PAN ID, member number, member and neighbour tables, mode
NON_PARTICIPATE = "non_participate"  # master -> robot: not selected, stay waiting
NOTIFY_ACK = "notify_ack"  # robot -> master
SLOT_ANNOUNCE = "slot_announce"  # master -> free candidates (broadcast): the open slots as subtasks (seed 003 Algorithm 2)
BID = "bid"  # candidate -> master: its own utility for each open slot it can take (empty: none)

TX_START = "tx_start"  # token holder -> swarm: transmission-start sign
TX_START_ACK = "tx_start_ack"
TOKEN = "token"  # token holder -> swarm: the number of the next robot
TOKEN_ACK = "token_ack"
SYNC = "sync"  # next holder -> swarm: switching IR roles now
HEADING = "heading"  # neighbour of the transmitter -> transmitter: bearing it saw it at

STATUS = "status"  # master -> slaves: driving speed and user activity (periodic)
DISPERSE = "disperse"  # master -> slaves
DISPERSE_ACK = "disperse_ack"

MODE_CHANGE = "mode_change"  # master -> swarm: new driving mode, member and neighbour tables (Table 3)
MODE_CHANGE_ACK = "mode_change_ack"
HANDOVER = "handover"  # old master -> new master: take over the user connection
HANDOVER_ACK = "handover_ack"

CANDIDACY = "candidacy"  # slave -> swarm: its claim to take the lost master's place (Table 3's rule, own measurements)
TAKEOVER = "takeover"  # elected slave -> swarm: it is the master now: its claim, member and neighbour tables
TAKEOVER_ACK = "takeover_ack"

MEMBER_UPDATE = "member_update"  # master -> swarm: a member removed or recruited: new total, member and neighbour tables (seed 003 §4.1.2)
MEMBER_UPDATE_ACK = "member_update_ack"
# a member whose sensor failed so that it cannot hold its slot -> master (seed 003 Algorithm 2 step 5: "it sends a
# request (bid) to the other robots"; the master, which holds the tables, runs the takeover)
BID_REQUEST = "bid_request"
BID_REQUEST_ACK = "bid_request_ack"

# Payload sizes (bytes of MAC payload; the PHY and MAC headers and the FCS are
# ``radio.frame_overhead_bytes``). Encoding (chosen): a frame kind 1 byte; a node id 2 (an 802.15.4
# short address); a PAN ID 2; a sequence number 2; a member number, a count, a mode, a shape or a
# state 1; a distance or an offset component 2 (int16 centimetres); a bearing or an angle 2 (int16,
# 0.001 rad); a speed 2 (int16 mm/s or mrad/s). A frame that carries a list or a table has a fixed
# part here and a part per entry (:data:`PER_ENTRY_BYTES`, :func:`payload_bytes`).
SIZE_BYTES = {
    SCAN: 4,  # kind, sequence, count of the robots already heard (+ 2 per robot listed)
    SCAN_RESPONSE: 4,  # kind, the scan's sequence, own state
    JOIN_QUERY: 4,  # kind, sequence, count of candidates (+ 2 per candidate)
    JOIN_ANSWER: 5,  # kind, the query's sequence, available (Table 1), own state
    STATUS_QUERY: 4,  # as the joining query: kind, sequence, count of candidates (+ 2 per candidate)
    # the joining answer (5) and seed 003's β_i = <id, w_i, P_rem_i> with the draws and the distance:
    # robot type 1, remaining battery 2 (mAh), wheel slip 1 (0.1 %), the servo, actuator and sensing
    # draws 2 each (mA; 0xFFFF = no such module), the sensors carried 1 (bit mask), the distance
    # estimate of the query 2 (int16 cm) — 13 bytes of status
    STATUS_ANSWER: 18,
    JOIN_NOTIFY: 7,  # kind, new PAN ID, member number, total members, mode, shape (+ member and neighbour tables)
    NON_PARTICIPATE: 4,  # kind, sequence, reason
    NOTIFY_ACK: 4,  # kind, the notification's sequence, status
    SLOT_ANNOUNCE: 5,  # kind, sequence 2, attempt, count of slots (+ per slot and per listed bidder)
    BID: 4,  # kind, the announcement's sequence 2, count of entries (+ per entry)
    TX_START: 4,  # kind, token sequence, holder's member number
    TX_START_ACK: 4,  # kind, token sequence, own member number
    TOKEN: 6,  # kind, token sequence, next member, holder's member, total members
    TOKEN_ACK: 4,  # kind, token sequence, own member number
    SYNC: 4,  # kind, token sequence, own member number
    HEADING: 6,  # kind, slot sequence, bearing, own member number
    STATUS: 24,  # kind, sequence, time stamp 4, (vx, vy, ω) 6, activity, mode, rotation flag, turn rate 2, user (x, y) 4, 2 spare
    DISPERSE: 4,  # kind, sequence, reason
    DISPERSE_ACK: 4,  # kind, sequence, own member number
    MODE_CHANGE: 6,  # kind, sequence, mode, shape, total members (+ member and neighbour tables)
    MODE_CHANGE_ACK: 4,  # kind, the change's sequence, own member number
    HANDOVER: 12,  # kind, sequence, user id 2, previous driving state, the belt's BLE address 6
    HANDOVER_ACK: 4,  # kind, sequence, status
    CANDIDACY: 8,  # kind, the lost master's id 2, own member number, the claim 2 (int16 cm), mode, LF antennas
    TAKEOVER: 11,  # kind, sequence 2, the lost master's id 2, the claim 2, own old member number, total members, mode, shape (+ tables)
    TAKEOVER_ACK: 4,  # kind, the takeover's sequence, own member number
    MEMBER_UPDATE: 8,  # kind, sequence 2, total members, mode, shape, removed count, added count (+ member and neighbour tables)
    MEMBER_UPDATE_ACK: 4,  # kind, the update's sequence, own member number
    BID_REQUEST: 6,  # kind, sequence, own member number, the sensors that work (bit mask), 1 spare
    BID_REQUEST_ACK: 4,  # kind, the request's sequence, status
}

# the member table: the node id of each member, in member-number order (chosen: 15 bits of short address
# and one bit that says whether the member's body carries the two LF antennas a master needs, robot_types)
MEMBER_ENTRY_BYTES = 2
LINK_ENTRY_BYTES = 6  # the neighbour table: member, its reference neighbour, the offset (x, y)
LIST_ENTRY_BYTES = 2  # a listed robot (node id)
# a slot of a slot announcement: member number 1, its distance from the master 2 (int16 cm), its
# sensing share 1 (exposed sides of 4), the slot's age 2 (0.01 s: t − t_j for the priority)
SLOT_ENTRY_BYTES = 6
BID_ENTRY_BYTES = 5  # member number 1, the utility 4 (float32)


WALK_BYTES = 2  # a handover for a broken part: the way the user walks (int16 mrad; modes.ModeManager.change)
REGION_BYTES = 2  # a refill's joining query: its available region (a distance, int16 cm; recovery.RecoveryManager.refill_region_m)


def _table_bytes(payload: dict) -> int:
    links = sum(len(lks) for lks in payload["links"].values())
    return MEMBER_ENTRY_BYTES * len(payload["members"]) + LINK_ENTRY_BYTES * links


# the variable part of a frame that carries a list or the tables, from its payload
PER_ENTRY_BYTES = {
    SCAN: lambda p: LIST_ENTRY_BYTES * len(p["known"]),
    JOIN_QUERY: lambda p: LIST_ENTRY_BYTES * len(p["candidates"]) + REGION_BYTES * ("region_m" in p),
    STATUS_QUERY: lambda p: LIST_ENTRY_BYTES * len(p["candidates"]) + REGION_BYTES * ("region_m" in p),
    JOIN_NOTIFY: _table_bytes,
    SLOT_ANNOUNCE: lambda p: SLOT_ENTRY_BYTES * len(p["slots"]) + LIST_ENTRY_BYTES * len(p["bidders"]),
    BID: lambda p: BID_ENTRY_BYTES * len(p["utilities"]),
    MODE_CHANGE: _table_bytes,
    TAKEOVER: _table_bytes,
    MEMBER_UPDATE: _table_bytes,
    HANDOVER: lambda p: WALK_BYTES * ("walk_rad" in p),
}

# The largest MAC payload of one 802.15.4 frame (aMaxPHYPacketSize 127 − 11 bytes of MAC header and
# FCS). The tables of a joining notification fit up to 14 members in a column, row or wedge (8n + 1
# bytes for n members) and 9 in a grid; a longer frame stands for its fragments: sent as one frame
# of the total length (their airtime, one loss draw) — a simplification, chosen.
MAX_PAYLOAD_BYTES = 116


# the kinds whose frames carry no list and no table: their payload size is the kind's alone
# (``payload_bytes(kind, p) == FIXED_BYTES[kind]`` for every payload ``p``), read by the station for
# every frame it sends (the token ring's, the heading exchange's and the status broadcast's frames)
FIXED_BYTES = {kind: size for kind, size in SIZE_BYTES.items() if kind not in PER_ENTRY_BYTES}


def payload_bytes(kind: str, payload: dict) -> int:
    """The payload size of a frame of ``kind`` carrying ``payload``."""
    extra = PER_ENTRY_BYTES.get(kind)
    return SIZE_BYTES[kind] + (extra(payload) if extra is not None else 0)
